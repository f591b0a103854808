"""pumpcyl.margins and pumpcyl.poles on a single-pump rig against the command line's
`margins --json` and `poles --json` (docs/circuits.md#modes-in-margins-and-poles)."""

import json
import math
import subprocess

import pumpcyl
from conftest import pumpcyl_binary


def cli(command):
    out = subprocess.run([pumpcyl_binary(), command, "--json", "--set", "circuit=single-pump"],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def test_margins_and_poles_give_the_modes_with_the_command_line_keys():
    rig = pumpcyl.Rig(circuit="single-pump")
    for command, result in [("margins", pumpcyl.margins(rig)), ("poles", pumpcyl.poles(rig))]:
        doc = cli(command)
        plain = result.to_dict()
        assert sorted(plain) == sorted(doc), command
        assert [sorted(m) for m in plain["modes"]] == [sorted(m) for m in doc["modes"]]
        # the loop's description names the rig as each front end knows it; the rest is equal
        plain.pop("loop")
        doc.pop("loop")
        assert plain == doc, command
        # the switching force by hand: 6.91 bar on the rod's annulus, 36 mm
        assert math.isclose(result["switching_force_n"], 6.91e5 * math.pi / 4 * 0.036**2,
                            rel_tol=1e-12)
        assert [(m["mode"], m["accumulator_chamber"], m["at_rest"])
                for m in result["modes"]] == [(1, 2, False), (2, 1, True)]
