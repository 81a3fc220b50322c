#!/usr/bin/env python3
"""A test table of known truth (docs/real-data.md): the closed-form 1X of an isotropic rotor
(critical speed 160 rad/s, damping ratio 0.03, e = 5 um) with 1 um of runout, 120 rows from 800
to 2585 rpm, one unnamed probe, no noise; written as a monitoring system would, in one of two
conventions. Used by tests/cli_test.sh and python/tests/test_rubref.py.
    closed_form_table.py OUT {um-0peak-lead|mil-pkpk-lag}"""
import cmath
import math
import sys

CRITICAL_RAD_S = 160.0
CONVENTIONS = {
    # header, amplitude in its unit from metres 0-peak, phase sign
    "um-0peak-lead": ("rpm,amp_1x_um,phase_1x_deg", lambda a: a * 1e6, 1.0),
    "mil-pkpk-lag": ("rpm,amp_1x,phase_1x_deg", lambda a: 2 * a / 25.4e-6, -1.0),
}


def write(path, convention):
    header, amplitude, sign = CONVENTIONS[convention]
    with open(path, "w") as f:
        f.write(header + "\n")
        for i in range(120):
            rpm = 800 + 15 * i
            w = rpm * 2 * math.pi / 60
            v = 5e-6 * w * w / complex(CRITICAL_RAD_S ** 2 - w * w, 2 * 0.03 * CRITICAL_RAD_S * w) + 1e-6 * cmath.exp(0.3j)
            f.write(f"{rpm},{amplitude(abs(v))!r},{sign * math.degrees(cmath.phase(v))!r}\n")


if __name__ == "__main__":
    write(sys.argv[1], sys.argv[2])
