"""hilcam.Scene: the same frames as host-sim, its truth, its errors, OpenCV."""

import json
import subprocess

import numpy as np
import pytest

import hilcam


def host_frame(host_sim, scene, tmp_path):
    """host-sim frame's frame.png (as the PNG holds it) and truth.json."""
    cv2 = pytest.importorskip("cv2")
    out = tmp_path / scene.stem
    subprocess.run([host_sim, "frame", "--scene", str(scene), "--out", str(out)], check=True, capture_output=True)
    png = cv2.imread(str(out / "frame.png"), cv2.IMREAD_UNCHANGED)
    if png.ndim == 3:
        png = png[:, :, ::-1]
    return png, json.loads((out / "truth.json").read_text())


def test_every_shipped_scene_renders_the_bytes_host_sim_frame_writes(host_sim, scenes, tmp_path):
    for path in sorted(scenes.glob("*.toml")):
        frame = hilcam.Scene.from_toml(path).render()
        png, truth = host_frame(host_sim, path, tmp_path)
        assert frame.image.dtype == png.dtype, path.name
        assert frame.image.shape == png.shape, path.name
        assert np.array_equal(frame.image, png), path.name
        assert frame.truth["fx"] == truth["fx"] and frame.truth["cy"] == truth["cy"], path.name
        assert frame.plan["chosen"], path.name


def test_text_and_file_give_the_same_scene(scenes):
    path = scenes / "standard.toml"
    a = hilcam.Scene.from_toml(path).render()
    b = hilcam.Scene.from_toml(path.read_text()).render()
    assert np.array_equal(a.image, b.image)


def test_formats_give_their_arrays(scenes):
    s = hilcam.Scene.from_toml(scenes / "standard.toml")
    w, h = s.size
    f = s.render()
    assert f.image.dtype == np.uint8 and f.image.shape == (h, w)
    s.set_format("gray16", 12)
    f = s.render()
    assert f.image.dtype == np.uint16 and f.dn.max() < 4096
    assert np.array_equal(f.image, f.dn << 4)
    s.set_format("rgb565")
    f = s.render()
    assert f.image.shape == (h, w, 3) and f.dn[..., 1].max() < 64


def test_a_pose_set_is_the_pose_rendered_and_its_truth(scenes):
    s = hilcam.Scene.from_toml(scenes / "standard.toml")
    before = s.render()
    R, T = s.pose
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-9)
    s.look_at(eye=T + np.array([0.05, 0.0, 0.0]), target=T + R[2], up=-R[1])
    moved = s.render()
    assert not np.array_equal(before.image, moved.image)
    assert np.allclose(moved.truth["T"], T + np.array([0.05, 0.0, 0.0]))
    s.set_pose(R, T)
    assert np.array_equal(s.render().image, before.image)


def test_exposure_scales_the_frame(scenes):
    s = hilcam.Scene.from_toml(scenes / "standard.toml")
    a = s.render().dn.astype(float)
    s.set_exposure(s.exposure / 2)
    b = s.render().dn.astype(float)
    assert b.mean() < 0.6 * a.mean()


def test_bad_values_raise_naming_the_field_and_leave_the_scene(scenes, tmp_path):
    s = hilcam.Scene.from_toml(scenes / "standard.toml")
    before = s.render().image
    with pytest.raises(hilcam.SceneError) as e:
        s.set_exposure(-1.0)
    assert e.value.field == "output.exposure", str(e.value)
    with pytest.raises(hilcam.SceneError) as e:
        s.look_at(eye=(0, 0, 1), target=(0, 0, 1))
    assert e.value.field.startswith("camera.pose"), str(e.value)
    with pytest.raises(hilcam.SceneError) as e:
        s.set_pose(np.diag([1.0, 1.0, 2.0]), (0, 0, 0))
    assert "camera.pose" in str(e.value)
    with pytest.raises(hilcam.SceneError) as e:
        s.set_format("gray16", 3)
    assert "output" in e.value.field, str(e.value)
    with pytest.raises(hilcam.SceneError):
        s.set_pose(np.eye(2), (0, 0, 0))
    assert np.array_equal(s.render().image, before)
    with pytest.raises(hilcam.SceneError) as e:
        hilcam.Scene.from_toml("name = 'x'\n[camera]\nwidth = 0\n")
    bad = tmp_path / "bad.toml"
    bad.write_text((scenes / "standard.toml").read_text().replace("exposure = 800.0", "exposure = -1.0", 1))
    with pytest.raises(hilcam.SceneError) as e:
        hilcam.Scene.from_toml(bad)
    assert e.value.field == "output.exposure" and "bad.toml" in str(e.value), str(e.value)
    with pytest.raises(hilcam.SceneError) as e:
        hilcam.Scene.from_toml(scenes / "no-such-scene.toml")
    assert "no-such-scene.toml" in str(e.value)


def test_opencv_gives_the_camera_in_opencv_conventions(scenes):
    cv2 = pytest.importorskip("cv2")
    s = hilcam.Scene.from_toml(scenes / "standard.toml")
    k, d, rvec, tvec, size = s.opencv()
    t = s.render().truth
    assert size == s.size
    assert np.allclose(k, t["K"])
    # OpenCV's camera looks along +z with y down: the contract's R with its
    # first two rows negated (camera-model.md §1); t = -R_cv T.
    r_cv = np.diag([-1.0, -1.0, 1.0]) @ np.array(t["R"])
    assert np.allclose(cv2.Rodrigues(rvec)[0], r_cv, atol=1e-9)
    assert np.allclose(tvec.ravel(), -r_cv @ np.array(t["T"]), atol=1e-9)
    e = s.export()
    assert e["distortion"]["residual_px"] < 1e-3
    # OpenCV itself images the export's world points where the emulator does.
    got, _ = cv2.projectPoints(np.array(e["world_points"]), rvec, tvec, k, d)
    err = np.linalg.norm(got.reshape(-1, 2) - np.array(e["pixels"]), axis=1)
    assert err.max() <= e["distortion"]["residual_px"] + 1e-6
