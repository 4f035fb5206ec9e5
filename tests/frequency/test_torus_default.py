"""Issue 32: `torus` defaults to the invariant circle where it applies (HB is 20-38 % off on
contact whatever its residual), HB results say their residual is not their error, and the
help says when to prefer which."""

from analysis.frequency.methods import TORUS, default_torus_method


def test_default_rule():
    assert default_torus_method("shaft,vc") == "shooting"
    assert default_torus_method("param:forcing,vc[left]") == "shooting"
    assert default_torus_method("shaft,vc", "8,4") == "hb"
    assert default_torus_method("vc[left],vc[right]") == "hb"
    assert default_torus_method("shaft,shaft") == "hb"
    assert set(TORUS) >= {"hb", "shooting"}


def test_help_says_when_to_prefer_which(cli):
    torus = " ".join(cli("torus", "--help", env={"COLUMNS": "200"}).stdout.split())
    hb = " ".join(cli("hb", "--help", env={"COLUMNS": "200"}).stdout.split())
    assert "Default: shooting" in torus and "20-38 %" in torus
    assert "prefer it there" in torus and "smooth forces" in torus
    assert "use `torus`" in hb and "2H" in hb


def test_hb_torus_prints_its_caution(cli, tmp_path):
    out = cli("torus", "vakharia2015", "--n-balls", "10", "--set", "speed_rpm=5000",
              "--harmonics", "4,2", "--lyapunov-duration", "0", "-o", str(tmp_path / "t.nc"))
    assert out.returncode == 0, out.stderr
    assert "note: the residual is not the error" in out.stdout
