"""python -m benchmarks FOLDER [--fluid | --paper | --identify] ...: the benchmark named by the flag (the solid
ladders without one); `tunnelquake bench` runs this."""
from __future__ import annotations

import sys


def main(argv: list[str]) -> int:
    if "--paper" in argv:  # the paper case's settings: benchmarks/paper.py
        from .paper import main as paper_main

        return paper_main([a for a in argv if a != "--paper"])
    if "--identify" in argv:  # the paper's open choices, one at a time: benchmarks/paper_study.py
        from .paper_study import main as identify_main

        return identify_main([a for a in argv if a != "--identify"])
    if "--fluid" in argv:  # water and coupled ladders, stock pimpleFoam ratio: benchmarks/fluid.py
        from .fluid import main as fluid_main

        return fluid_main([a for a in argv if a != "--fluid"])
    from .solid import main as solid_main

    return solid_main(argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
