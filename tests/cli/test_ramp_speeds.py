"""Issue 32: a ramped run says which speeds its file kept, and what its transient dropped."""


def test_ramp_says_kept_and_dropped(cli, tmp_path):
    out = cli("simulate", "vakharia2015", "--speed-rpm", "1000:10000", "--duration", "0.4",
              "--transient", "0.1", "-o", str(tmp_path / "r.nc"))
    assert out.returncode == 0, out.stderr
    assert "kept speeds 3250 → 10000 rpm (t = 0.1…0.4 s); the transient dropped 1000 → " \
           "3250 rpm (--transient 0 keeps the whole ramp)" in out.stdout
    whole = cli("simulate", "vakharia2015", "--speed-rpm", "1000:10000", "--duration", "0.2",
                "--transient", "0", "-o", str(tmp_path / "w.nc"))
    assert "kept speeds 1000 → 10000 rpm" in whole.stdout and "dropped" not in whole.stdout


def test_constant_speed_says_nothing_of_a_ramp(cli, tmp_path):
    out = cli("simulate", "vakharia2015", "--duration", "0.05", "--transient", "0",
              "-o", str(tmp_path / "c.nc"))
    assert out.returncode == 0 and "kept speeds" not in out.stdout
