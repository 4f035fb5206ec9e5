"""`bearingdyn calibrate`: bad input is one line, exit 2, nothing written; targets and
priors parse and check against the model."""

from __future__ import annotations

import pytest

from analysis.errors import InputError
from analysis.inference.priors import parse_prior
from analysis.inference.targets import class_matches, load_target, parse_target
from analysis.model import load_model

PRIORS = ("--prior", "rotor_mass:0.1:10:log", "--prior", "damping:10:3162:log")


def _target(tmp_path, text: str) -> str:
    path = tmp_path / "t.toml"
    path.write_text(text)
    return str(path)


ROW = '[[rows]]\nn_balls = 7\nclass = "chaotic"\n'


@pytest.mark.parametrize("args, words", [
    (("--prior", "rotor_weight:0.1:10"), "--prior rotor_weight: not a parameter"),
    (("--prior", "damping:300:10"), "--prior damping: LO must be < HI"),
    (("--prior", "damping:0:100:log"), "a log prior needs LO > 0"),
    ((*PRIORS, "--samples", "0"), "--samples: must be a whole number in [2, 200000]"),
    ((*PRIORS, "--rounds", "0"), "--rounds: must be a whole number in [1, 30]"),
    ((*PRIORS, "--samples", "200000", "--rounds", "30"), "core-hours, above 100"),
    ((*PRIORS, "--target", "no-such-table"), "--target: must be a built-in target"),
])
def test_bad_input_one_line_exit_2_nothing_written(cli, tmp_path, args, words):
    out = tmp_path / "cal.nc"
    base = ["calibrate", "vakharia2015", "-o", str(out)]
    if "--target" not in args:
        base += ["--target", "paper-table2"]
    res = cli(*base, *args)
    assert res.returncode == 2, res.stderr
    lines = [line for line in res.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and words in lines[0], res.stderr
    assert list(tmp_path.iterdir()) == []


BAD_TARGETS = [
    ('[[rows]]\nn_balls = 7\nclass = "chaos"\n', "rows[0].class: must be one of"),
    ('[[rows]]\nn_balls = 7\nmajor = { x = "VC+9X" }\n', "rows[0].major.x: must be a line"),
    ('[[rows]]\nn_balls = 7\npresent = { x = ["BPFO"] }\n', "rows[0].present.x"),
    ('[[rows]]\nn_balls = 7\nmajor = { z = "X" }\n', "rows[0].major: must be a coordinate"),
    ('[[rows]]\nn_balls = { left = 7 }\nclass = "chaotic"\n', "has no bearing 'left'"),
    ('[[rows]]\nn_balls = 40\nclass = "chaotic"\n', "rows[0].n_balls: must be a whole number"),
    ('name = "empty"\n', "an empty target"),
    (ROW + 'rotor_weight = 3.0\n', "rows[0].rotor_weight: not a parameter"),
]


@pytest.mark.parametrize("text, words", BAD_TARGETS)
def test_bad_target_refused_before_any_work(tmp_path, text, words):
    from analysis.inference.abc import prepare

    with pytest.raises(InputError) as err:
        prepare("vakharia2015", _target(tmp_path, text), PRIORS[1::2])
    assert words in str(err.value) and "\n" not in str(err.value)


def test_bad_target_one_line_exit_2(cli, tmp_path):
    target = _target(tmp_path, BAD_TARGETS[0][0])
    out = tmp_path / "cal.nc"
    res = cli("calibrate", "vakharia2015", "--target", target, *PRIORS, "-o", str(out))
    assert res.returncode == 2, res.stderr
    lines = [line for line in res.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and BAD_TARGETS[0][1] in lines[0], res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.toml"]


def test_paper_target_reads_table2():
    from analysis.reports.paper import PAPER_TABLE2

    model = load_model("vakharia2015")
    target = load_target("paper-table2", model)
    assert [r.n_balls for r in target.rows] == sorted(PAPER_TABLE2)
    for row in target.rows:
        paper = PAPER_TABLE2[row.n_balls]
        assert dict(row.major) == {"x": paper.major_x, "y": paper.major_y}
        assert dict(row.present).get("x", ()) == paper.others_x
        assert dict(row.present).get("y", ()) == paper.others_y
        assert dict(row.parameters) == {"speed_rpm": 5000.0}
    # the paper's "multi-orbit periodic": a periodic orbit of k >= 2 shaft revolutions
    assert target.rows[-1].classes == ("periodic-k",)


def test_class_words():
    assert class_matches(("periodic-k",), "periodic-3")
    assert not class_matches(("periodic-k",), "periodic-1")
    assert class_matches(("periodic",), "periodic-1")
    assert class_matches(("periodic-k", "quasi-periodic"), "quasi-periodic")
    assert not class_matches(("chaotic",), "diverged")
    assert class_matches(("diverged",), "diverged")


def test_prior_maps_unit_cube_log_and_linear():
    log = parse_prior("damping:10:1000:log")
    assert log.from_unit(0.5) == pytest.approx(100.0)
    assert log.to_unit(1000.0) == pytest.approx(1.0)
    lin = parse_prior("rotor_mass:1:3")
    assert lin.from_unit(0.25) == pytest.approx(1.5)
    with pytest.raises(InputError, match=r"^prior: must be NAME:LO:HI"):
        parse_prior("damping:10")


def test_target_needs_an_observation():
    model = load_model("vakharia2015")
    with pytest.raises(InputError, match="observes nothing"):
        parse_target({"rows": [{"n_balls": 7}]}, model)


def test_a_run_that_blew_up_is_the_class_diverged_and_a_miss():
    """A member whose record is not finite (or that the kernel flags) is ``diverged``: kept
    in the round and counted as a missed row, never dropped."""
    import numpy as np

    from analysis.inference import simulate as sim
    from analysis.inference.abc import row_marks
    from analysis.model import as_system

    model = load_model("vakharia2015")
    target = load_target("paper-table2", model)
    system = as_system(model, 6)
    samples = np.full((400, 4), 1e-6)
    samples[300:] = np.nan
    row = sim._member_row(system, samples, np.nan, np.nan, 1e-5, 30, 0, 9000,
                          sim.RunSettings(), ("x", "y"))
    assert row.nature == "diverged" and row.diverged_at == pytest.approx(0.09)
    assert row_marks(target.rows[0], row) == (False, False)
    assert class_matches(("diverged",), row.nature)
