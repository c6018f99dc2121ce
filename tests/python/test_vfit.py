# SPDX-License-Identifier: Apache-2.0
"""The Python module `vfit` against the CLI and the engine: a fit equals `vfit fit`'s bit for bit
(same body, garment and thread count), arrays are zero-copy views, bad input raises vfit.Error
naming the element, and a dressed character steps as vfit.animate plays."""
import json
import os
import subprocess

import numpy as np
import pytest

import vfit

CLI = os.environ.get("VFIT_CLI")


def test_version_and_commit():
    assert vfit.__version__.count(".") == 2
    assert vfit.git_commit


def test_mesh_arrays_are_read_only_views():
    positions = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float64)
    mesh = vfit.Mesh(positions, np.array([[0, 1, 2]]))
    assert mesh.vertex_count == 3 and mesh.triangle_count == 1
    p = mesh.positions
    assert p.dtype == np.float32 and p.shape == (3, 3)
    assert not p.flags.writeable
    assert np.shares_memory(p, mesh.positions), "two reads see the same memory: no copy"
    del mesh
    assert p[1, 0] == 1.0, "a view keeps its mesh alive"


def test_bad_input_raises_naming_the_element(tmp_path):
    with pytest.raises(vfit.Error, match="triangle 0 names vertex 7"):
        vfit.Mesh(np.zeros((3, 3)), np.array([[0, 1, 7]]))
    with pytest.raises(vfit.Error, match="vertex 2 is not finite"):
        vfit.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]]), np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match=r"\(V, 3\)"):
        vfit.Mesh(np.zeros((3, 2)), np.array([[0, 1, 2]]))
    missing = str(tmp_path / "missing.obj")
    with pytest.raises(vfit.Error, match="missing.obj"):
        vfit.read_mesh(missing)
    with pytest.raises(vfit.Error, match="height"):
        vfit.Body.mannequin({"height": 5.0}, vertices=2000)
    with pytest.raises(ValueError, match="75 numbers"):
        vfit.Body.mannequin(vertices=2000).set_pose(np.zeros(10))


@pytest.mark.skipif(not CLI, reason="VFIT_CLI names no vfit executable")
def test_the_demo_outfit_fits_as_the_cli_fits_it_bit_for_bit(tmp_path):
    # The demo outfit: catalogue trousers and a tee modelled in T-pose, on the mannequin in the
    # demo pose, with the cloth simulation, through the CLI and through the module.
    files = []
    for kind, size in (("trousers", "P2"), ("tee", "M")):
        garment = vfit.catalogue_garment(kind, size, "tpose", vertices=1500)
        files.append(str(tmp_path / f"{kind}.ply"))
        vfit.write_mesh(files[-1], garment)
    out_file, report_file = str(tmp_path / "fit.glb"), str(tmp_path / "fit.json")
    args = [CLI, "fit", "--pose", "demo", "--out", out_file, "--report", report_file, "--quiet"]
    for f in files:
        args += ["--garment", f]
    subprocess.run(args, check=True)

    body = vfit.Body.mannequin()
    body.set_pose("demo")
    result = vfit.fit(body, [vfit.read_mesh(f) for f in files], names=files)
    with open(report_file) as f:
        cli_report = json.load(f)
    report = result.report
    assert report["vfit"] == cli_report["vfit"]
    assert report["verdict"] == cli_report["verdict"] == result.verdict
    for g in range(2):
        assert report["garments"][g]["penetration"] == cli_report["garments"][g]["penetration"]
    # The .glb holds the body and the garments as labelled meshes, in that order.
    scene = vfit.read_mesh(out_file)
    positions = scene.positions
    start = body.mesh.vertex_count
    np.testing.assert_array_equal(positions[:start], body.mesh.positions)
    for garment in result.garments:
        np.testing.assert_array_equal(positions[start:start + garment.vertex_count], garment.positions)
        start += garment.vertex_count
    assert start == scene.vertex_count


def test_dressed_character_steps_as_animate_plays():
    body = vfit.Body.mannequin(vertices=3000)
    tee = vfit.catalogue_garment("tee", "M", "apose", vertices=1200)
    result = vfit.fit(body, [tee], simulate=False, threads=2)
    poses = np.zeros((5, 75))
    poses[:, 3 * 18 + 1] = np.linspace(0, 0.5, 5)  # the left elbow bends
    played = vfit.animate(body, result, poses, fps=30, threads=2)
    assert len(played) == 1 and played[0].shape == (5, 1200, 3)

    character = vfit.DressedCharacter(body, result, threads=2)
    for f in range(5):
        frame = character.step(poses[f], 1 / 30)
        assert frame["total_ms"] > 0
        np.testing.assert_array_equal(character.garment_positions(0), played[0][f])
    assert np.isfinite(played[0]).all()

    body.set_pose("demo")
    posed_fit = vfit.fit(body, [tee], simulate=False, threads=2)
    with pytest.raises(ValueError, match="posed body"):
        vfit.DressedCharacter(body, posed_fit)
