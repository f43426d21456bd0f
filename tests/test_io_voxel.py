"""Voxel images of packs (pp.io.voxelize) and their writers (.npy, .tif stack, .vti)."""

import json

import numpy as np
import pytest

import polypack as pp
from polypack.errors import InvalidInputError


def _two_spheres():
    return pp.Packing(np.array([[0.5, 0.5, 0.5], [1.5, 1.5, 1.5]]), np.array([0.3, 0.2]), np.array([2.0, 2.0, 2.0]),
                      species=[0, 1])


def test_labels_follow_the_voxel_centres_and_wrap_periodically():
    # a sphere across the periodic corner: every voxel whose centre lies within r of the
    # centre's periodic images carries label 1 + species, all others 0
    pk = pp.Packing(np.array([[0.02, 1.98, 0.9]]), np.array([0.37]), np.array([2.0, 2.0, 2.0]), species=[0])
    im = pp.io.voxelize(pk, 20)
    h = 0.1
    c = (np.arange(20) + 0.5) * h
    d = [np.minimum(np.abs(c - x0), 2.0 - np.abs(c - x0)) for x0 in (0.02, 1.98, 0.9)]
    inside = (d[0][:, None, None] ** 2 + d[1][None, :, None] ** 2 + d[2][None, None, :] ** 2) < 0.37 ** 2
    assert im.labels.dtype == np.uint8 and im.shape == (20, 20, 20)
    assert np.array_equal(im.labels == 1, inside)
    assert im.labels.max() == 1


def test_exact_voxel_and_subvoxel_fractions():
    im = pp.io.voxelize(_two_spheres(), 64, subsamples=4)
    exact = np.array([4 / 3 * np.pi * 0.3 ** 3, 4 / 3 * np.pi * 0.2 ** 3]) / 8.0
    assert im.exact_fractions[1:] == pytest.approx(exact, rel=1e-12)
    assert im.exact_fractions.sum() == pytest.approx(1.0, abs=1e-14)
    # voxel counts carry a staircase error of a few per cent, the sub-voxel field far less
    assert im.voxel_inclusion_fraction == pytest.approx(exact.sum(), rel=0.03)
    assert im.subvoxel_inclusion_fraction == pytest.approx(exact.sum(), rel=2e-3)
    assert im.voxel_fractions.sum() == pytest.approx(1.0)
    assert np.all((im.fraction >= 0) & (im.fraction <= 1))
    # voxels wholly inside a sphere are full, wholly outside empty
    assert np.all(im.fraction[im.labels == 0] < 0.75) and np.all(im.fraction[im.labels > 0] > 0.25)


def test_2d_pack_gives_a_2d_image_and_anisotropic_boxes_keep_voxels_near_cubic():
    pk = pp.Packing(np.array([[0.05, 0.5]]), np.array([0.3]), np.array([2.0, 1.5]))
    im = pp.io.voxelize(pk, 64, subsamples=4)
    assert im.shape == (64, 48) and im.spacing == pytest.approx([2 / 64, 1.5 / 48])
    assert im.exact_fractions[1] == pytest.approx(np.pi * 0.09 / 3.0)
    assert im.subvoxel_inclusion_fraction == pytest.approx(np.pi * 0.09 / 3.0, rel=2e-3)


def test_bad_input_is_rejected_with_the_value():
    with pytest.raises(InvalidInputError, match="resolution=1"):
        pp.io.voxelize(_two_spheres(), 1)
    with pytest.raises(InvalidInputError, match="subsamples=-1"):
        pp.io.voxelize(_two_spheres(), 8, subsamples=-1)
    with pytest.raises(InvalidInputError, match="packing must be"):
        pp.io.voxelize(np.zeros((3, 3)), 8)
    with pytest.raises(InvalidInputError, match=r"\.png"):
        pp.io.write_image("x.png", pp.io.voxelize(_two_spheres(), 8))


def test_writers_round_trip(tmp_path):
    # an image without symmetry between the axes (a transposed write would not match)
    pk = pp.Packing(np.array([[0.3, 1.1, 1.7], [1.5, 0.4, 0.6]]), np.array([0.3, 0.2]), np.array([2.0, 2.0, 2.0]),
                    species=[0, 1])
    im = pp.io.voxelize(pk, 16, subsamples=2)
    assert not np.array_equal(im.labels, im.labels.transpose(2, 1, 0))
    pp.io.write_image(tmp_path / "a.npy", im)
    assert np.array_equal(np.load(tmp_path / "a.npy"), im.labels)
    pp.io.write_image(tmp_path / "a.tif", im)
    from PIL import Image

    tif = Image.open(tmp_path / "a.tif")
    assert tif.n_frames == 16
    pages = []
    for k in range(16):
        tif.seek(k)
        pages.append(np.array(tif))
    assert np.array_equal(np.stack(pages, axis=0).transpose(2, 1, 0), im.labels)  # pages z, rows y, columns x
    assert json.loads(tif.tag_v2[270])["spacing"] == pytest.approx(im.spacing.tolist())
    pp.io.write_image(tmp_path / "a.vti", im)
    vtk = pytest.importorskip("vtk")
    from vtk.util.numpy_support import vtk_to_numpy

    r = vtk.vtkXMLImageDataReader()
    r.SetFileName(str(tmp_path / "a.vti"))
    r.Update()
    out = r.GetOutput()
    assert out.GetDimensions() == (17, 17, 17)
    assert out.GetSpacing() == pytest.approx((0.125, 0.125, 0.125))
    lab = vtk_to_numpy(out.GetCellData().GetArray("phase")).reshape(16, 16, 16).transpose(2, 1, 0)
    assert np.array_equal(lab, im.labels)
    fr = vtk_to_numpy(out.GetCellData().GetArray("inclusion_fraction")).reshape(16, 16, 16).transpose(2, 1, 0)
    assert np.array_equal(fr, im.fraction)
    assert not list(tmp_path.glob(".*.tmp"))


def test_cli_voxelize(tmp_path):
    from typer.testing import CliRunner

    from polypack.cli import app

    pp.io.write(tmp_path / "p.gsd", _two_spheres())
    res = CliRunner().invoke(app, ["voxelize", str(tmp_path / "p.gsd"), str(tmp_path / "p.vti"), "--resolution", "12",
                                   "--subsamples", "2"])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "p.vti").is_file()
    assert "exact" in res.output and "voxel" in res.output
