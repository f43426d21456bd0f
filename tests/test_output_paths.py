"""Safe output paths: only regular files are written, symlinks are written through, bad
destinations are refused with one line before anything is computed.

Every special file here is made by the test in its own tmp folder (mknod / mkfifo /
socket); no system device is ever touched.
"""

import json
import os
import socket
import stat

import numpy as np
import pytest

import polypack as pp
from polypack._util import atomic_open, check_output_folder, output_path
from polypack.cli import main
from polypack.errors import OutputError


@pytest.fixture(scope="module")
def small():
    return pp.pack(np.ones(40), 0.3, seed=1)


def _char_device(tmp_path):
    node = tmp_path / "nulldev"
    try:
        os.mknod(node, 0o666 | stat.S_IFCHR, os.makedev(1, 3))  # our own node, like /dev/null
    except (PermissionError, OSError):
        pytest.skip("mknod of a character device needs privileges")
    return node


def _specials(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    sock_path = tmp_path / "sock"
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.bind(str(sock_path))
    folder = tmp_path / "folder.gsd"
    folder.mkdir()
    return {"FIFO": fifo, "socket": sock_path, "folder": folder}, s


def test_special_files_are_refused_and_left_alone(tmp_path, small):
    specials, sock = _specials(tmp_path)
    try:
        try:
            specials["character device"] = _char_device(tmp_path)
        except pytest.skip.Exception:
            pass
        for what, node in specials.items():
            before = os.lstat(node)
            target = node if what == "folder" else node.with_name(node.name)
            with pytest.raises(OutputError, match=what.split()[0]) as info:
                pp.io.write(target if what == "folder" else str(node), small, format="gsd")
            assert "\n" not in str(info.value)
            after = os.lstat(node)
            assert stat.S_IFMT(after.st_mode) == stat.S_IFMT(before.st_mode) and after.st_ino == before.st_ino
            assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    finally:
        sock.close()


def test_symlink_is_written_through_and_kept(tmp_path, small):
    real = tmp_path / "real.gsd"
    pp.io.write(real, pp.pack(np.ones(30), 0.3, seed=5))
    link = tmp_path / "link.gsd"
    link.symlink_to(real)
    pp.io.write(link, small)
    assert link.is_symlink() and os.readlink(link) == str(real)
    assert np.array_equal(pp.io.read(real).positions, small.positions)
    # a dangling link creates the file it points to
    dang = tmp_path / "dangling.xyz"
    dang.symlink_to(tmp_path / "new.xyz")
    pp.io.write(dang, small)
    assert dang.is_symlink() and (tmp_path / "new.xyz").is_file()
    # a link to a special file is refused like the file itself
    fifo = tmp_path / "f"
    os.mkfifo(fifo)
    lf = tmp_path / "lf.csv"
    lf.symlink_to(fifo)
    with pytest.raises(OutputError, match="FIFO"):
        pp.io.write(lf, small)
    assert lf.is_symlink()


def test_file_as_parent_and_read_only_folder(tmp_path, small, monkeypatch):
    f = tmp_path / "plain"
    f.write_text("x\n")
    with pytest.raises(OutputError, match="is a file, not a folder"):
        pp.io.write(f / "sub" / "a.gsd", small)
    ro = tmp_path / "ro"
    ro.mkdir()
    real_access = os.access
    # root may write anywhere, so the read-only folder is the OS's answer for it
    monkeypatch.setattr(os, "access", lambda p, m, **kw: False if os.fspath(p) == str(ro) else real_access(p, m))
    with pytest.raises(OutputError, match="not writable"):
        pp.io.write(ro / "a.gsd", small)
    with pytest.raises(OutputError, match="not writable"):
        check_output_folder(ro)


def test_run_folder_that_is_a_file_is_refused_before_computing(tmp_path):
    f = tmp_path / "results"
    f.write_text("not a folder\n")
    study = {"study": {"name": "t", "seed": 1, "realizations": 1},
             "psd": {"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": 60},
             "protocol": {"kind": "crm", "volume_fraction": 0.4}, "output": {"plots": False}}
    with pytest.raises(OutputError, match="not a folder"):
        pp.ensemble.run_study(study, f)
    assert f.read_text() == "not a folder\n"


def _cli(args, capsys):
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    return info.value.code, capsys.readouterr().err


def test_cli_refuses_bad_destinations_with_one_line_before_packing(tmp_path, capsys, monkeypatch):
    import polypack.generate.lubachevsky as lub

    monkeypatch.setattr(lub, "pack", lambda *a, **k: pytest.fail("computed before checking the destination"))
    fifo = tmp_path / "fifo.gsd"
    os.mkfifo(fifo)
    (tmp_path / "d.gsd").mkdir()
    (tmp_path / "plain").write_text("x\n")
    for dest in (fifo, tmp_path / "d.gsd", tmp_path / "plain" / "x.gsd"):
        code, err = _cli(["pack", "--n", "50", "-o", dest], capsys)
        assert code == 1 and err.startswith("error: ") and len(err.strip().splitlines()) == 1, err
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    code, err = _cli(["pack", "--n", "50", "-o", tmp_path / "a.gsd", "--checkpoint", tmp_path / "a.gsd"], capsys)
    assert code == 1 and "must differ" in err


def test_cli_study_folder_and_run_out_file(tmp_path, capsys):
    code, err = _cli(["run", tmp_path], capsys)
    assert code == 1 and "is a folder" in err and len(err.strip().splitlines()) == 1
    st = tmp_path / "s.toml"
    st.write_text('[study]\nname = "t"\nrealizations = 1\n[psd]\nmodel = "bimodal"\nsize_ratio = 0.5\n'
                  'volume_ratio = 0.5\nn = 60\n[protocol]\nkind = "crm"\nvolume_fraction = 0.4\n')
    f = tmp_path / "file"
    f.write_text("x\n")
    code, err = _cli(["run", st, "--out", f], capsys)
    assert code == 1 and "not a folder" in err and len(err.strip().splitlines()) == 1


def test_cli_bad_scheduler_address_is_one_line(tmp_path, capsys):
    import dask.distributed  # noqa: F401  (in the test extra: a missing install fails, never skips)
    st = tmp_path / "s.toml"
    st.write_text('[study]\nname = "t"\nrealizations = 1\n[psd]\nmodel = "bimodal"\nsize_ratio = 0.5\n'
                  'volume_ratio = 0.5\nn = 60\n[protocol]\nkind = "crm"\nvolume_fraction = 0.4\n')
    from polypack.ensemble import dask_helpers

    with pytest.raises(pp.InvalidInputError, match="cannot connect"):
        with dask_helpers.dask_executor(address="tcp://127.0.0.1:1", timeout="1s"):
            pass
    code, err = _cli(["run", st, "--out", tmp_path / "o", "--scheduler", "not-an-address::"], capsys)
    assert code == 1 and "--scheduler" in err and len(err.strip().splitlines()) == 1, err


def test_json_dash_is_stdout_and_symlinked_json_is_kept(tmp_path, small, capsys):
    src = tmp_path / "a.gsd"
    pp.io.write(src, small)
    assert main(["analyze", str(src), "--contacts", "--json", "-"]) == 0
    out = capsys.readouterr().out
    assert json.loads(out)["contacts"]["coordination"] >= 0
    real = tmp_path / "r.json"
    real.write_text("{}\n")
    link = tmp_path / "link.json"
    link.symlink_to(real)
    main(["analyze", str(src), "--contacts", "--json", str(link)])
    assert link.is_symlink() and "contacts" in json.loads(real.read_text())


def test_output_path_accepts_new_nested_and_existing_regular_files(tmp_path):
    assert output_path(tmp_path / "new" / "deeper" / "x.gsd") == tmp_path / "new" / "deeper" / "x.gsd"
    p = tmp_path / "x.csv"
    with atomic_open(p, "w") as fh:
        fh.write("a\n")
    assert output_path(p) == p and p.read_text() == "a\n"
