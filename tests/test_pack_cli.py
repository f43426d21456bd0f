"""CLI ``polypack pack``."""

import numpy as np
import pytest

from polypack import io
from polypack._cli.pack_commands import sizes_from_options
from polypack.cli import main


def test_bimodal_counts_seed000():
    radii, species = sizes_from_options(2000, 1.0, 0.313, 0.333)
    assert np.bincount(species).tolist() == [168, 1832]
    assert radii[species == 1][0] == pytest.approx(0.313)


def test_cli_pack_writes_file(tmp_path, capsys):
    out = tmp_path / "p.gsd"
    main(["pack", "--n", "200", "--radius", "0.5", "--volume-fraction", "0.5", "--seed", "3", "-o", str(out)])
    pk = io.read(out)
    assert pk.n == 200
    assert pk.volume_fraction == pytest.approx(0.5, rel=1e-9)
    assert pk.min_gap() >= 0
    assert "target" in capsys.readouterr().out
    # continue from the written pack to a higher fraction
    out2 = tmp_path / "p2.gsd"
    main(["pack", str(out), "--volume-fraction", "0.55", "--seed", "4", "-o", str(out2)])
    pk2 = io.read(out2)
    assert pk2.volume_fraction == pytest.approx(0.55, rel=1e-9)
    # one growth rate throughout
    main(["pack", "--n", "200", "--volume-fraction", "0.5", "--fast-growth", "1", "-o", str(out2)])
    assert io.read(out2).meta["fast_start"] is None


def test_cli_pack_size_csv(tmp_path, capsys):
    f = tmp_path / "sizes.csv"
    f.write_text("radius,species\n" + "".join(f"{1.0 if k < 20 else 0.5},{0 if k < 20 else 1}\n" for k in range(150)))
    main(["pack", str(f), "--volume-fraction", "0.45", "--seed", "1"])
    assert "volume_fraction=0.450000" in capsys.readouterr().out


def test_cli_pack_errors(capsys):
    with pytest.raises(SystemExit) as e:
        main(["pack", "--n", "1"])
    assert e.value.code == 1
    assert "at least 2" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["pack", "--n", "20", "--volume-fraction", "dense"])
    assert "jammed" in capsys.readouterr().err
