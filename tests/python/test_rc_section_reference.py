"""The M–N capacities that tests/cpp/test_material_rc.cpp's pushover reaches: design/capacity.py's
M_Rd(N) of the 0.5 m strip with ø16 @ 200 mm at both faces (γc = γs = 1, α_cc = 1, parabola–
rectangle). The C++ test holds these numbers; this test keeps them equal to capacity.py's."""
import pytest

from tunnelquake.design.capacity import Concrete, RCSection, Reinforcement

# N (compression, N/m) -> M_Rd (N·m/m) as written in tests/cpp/test_material_rc.cpp
CPP_REFERENCE = {0.0: 230683.33155776808, 2e6: 628372.0379816361, 5e6: 1022799.3079584776}


@pytest.mark.parametrize("N", sorted(CPP_REFERENCE))
def test_capacity_py_gives_the_cpp_tests_reference(N):
    s = RCSection(0.5, Concrete(30e6), Reinforcement(500e6, 200e9), As_top=1005e-6, As_bottom=1005e-6,
                  d_top=0.05, d_bottom=0.05, gamma_c=1.0, gamma_s=1.0)
    assert s.moment_resistance(N)[0] == pytest.approx(CPP_REFERENCE[N], rel=1e-9)
