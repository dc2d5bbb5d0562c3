"""TunnelQuake's benchmarks: run time against error of the verification cases, the water and
coupled ladders, the paper case's shortcuts, the suite's parallel speed-up and the water step's
cost against the stock set-up. Not part of the installed `tunnelquake` package: they run from the
repository (they need its build, cases and docs), as `python -m benchmarks ...` from the root or
through `tunnelquake bench ...`, which starts that.

    solid.py        the solid verification ladders, --peer CalculiX (calculix.py), --stress
    fluid.py        --fluid: the rigid pipe (2D, 3D) and the ring ladders, stock pimpleFoam ratio
    paper.py        --paper: the paper case's settings, error against wall time
    suite.py        python -m benchmarks.suite: a suite's members on 1 and 2 workers
    water_step/     python -m benchmarks.water_step.benchmark: one water step, stock against ours
    fluid_common/   the water case builders shared with the verification tests
    common.py       machine line, observed orders, cheapest-run table, docs section replacement
"""
