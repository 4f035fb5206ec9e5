"""A bearing that carries no load at the static equilibrium is said so (issue 32, section
4): by ``stiffness`` and ``simulate``, from the balls whose load changes with displacement."""

from __future__ import annotations

import json

from analysis.model import as_system
from analysis.stability.statics import (
    balls_in_contact,
    equilibrium,
    static_load_note,
    unloaded_note,
)


def test_balls_in_contact_counts_only_touching_balls():
    system = as_system("vakharia2015", 13, radial_load=0.0)
    assert balls_in_contact(system, [0.0, 0.0]) == {"bearing": (0, 13)}
    loaded = as_system("vakharia2015", 13)
    found = equilibrium(loaded)
    touching, n = balls_in_contact(loaded, found.position)["bearing"]
    assert n == 13 and 1 <= touching < 13  # the loaded zone only
    # pushed past the clearance along x, the balls on that side touch
    clearance = float(system.parameters["radial_clearance"])
    assert balls_in_contact(system, [2 * clearance, 0.0])["bearing"][0] > 0


def test_note_names_the_idle_bearing_and_only_it():
    note = unloaded_note({"left": (0, 9), "right": (3, 9)})
    assert note is not None and "'left'" in note and "'right'" not in note
    assert "no load at the static equilibrium" in note
    assert unloaded_note({"bearing": (2, 8)}) is None
    assert static_load_note("vakharia2015", 13) is None
    assert "'bearing'" in static_load_note("vakharia2015", 13, radial_load=0.0)


def test_stiffness_and_simulate_print_the_note(cli, tmp_path):
    done = cli("stiffness", "vakharia2015", "--n-balls", "13", "--set", "radial_load=0",
               "--angles", "2")
    assert done.returncode == 0, done.stderr
    assert "carries no load at the static equilibrium" in done.stdout
    done = cli("stiffness", "vakharia2015", "--n-balls", "13", "--angles", "2", "--json")
    assert done.returncode == 0 and "carries no load" not in done.stdout + done.stderr
    assert json.loads(done.stdout)["balls_in_contact"]["bearing"] >= 1
    done = cli("simulate", "vakharia2015", "--n-balls", "13", "--set", "radial_load=0",
               "--duration", "0.01", "--transient", "0", "-o", str(tmp_path / "r.nc"))
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1].startswith("note: bearing 'bearing'")
