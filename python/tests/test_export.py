"""host-sim export's calibration files, as the tools that read them do:
PyYAML (YAML 1.1, what ROS's camera_calibration_parsers uses) and OpenCV's
FileStorage."""

import json
import subprocess

import numpy as np
import pytest

import hilcam


def export(host_sim, scene, out):
    r = subprocess.run([host_sim, "export", "--scene", str(scene), "--out", str(out)],
                       capture_output=True, text=True)
    return r


def test_ros_and_opencv_yaml_are_typed_under_yaml_1_1(host_sim, scenes, tmp_path):
    yaml = pytest.importorskip("yaml")
    cv2 = pytest.importorskip("cv2")
    base = (scenes / "checkerboard-barrel.toml").read_text()
    # A name that would inject keys is not a scene name: refused naming it.
    evil = tmp_path / "evil.toml"
    evil.write_text(base.replace('name = "checkerboard-barrel"',
                                 "name = " + json.dumps('evil: name\nimage_width: 1 # "quoted"'), 1))
    with pytest.raises(hilcam.SceneError) as e:
        hilcam.Scene.from_toml(evil)
    assert e.value.field == "name", str(e.value)
    # A name YAML would read as a number unquoted: it stays a string.
    name = "1e5"
    text = base.replace('name = "checkerboard-barrel"', "name = " + json.dumps(name), 1)
    scene_file = tmp_path / "numeric.toml"
    scene_file.write_text(text)
    scene = hilcam.Scene.from_toml(scene_file)
    assert scene.name == name
    r = export(host_sim, scene_file, tmp_path / "out")
    assert r.returncode == 0, r.stderr
    ros = yaml.safe_load((tmp_path / "out" / "ros.yaml").read_text())
    assert ros["camera_name"] == name
    assert ros["image_width"] == scene.size[0]
    k, dist, rvec, tvec, _ = scene.opencv()
    for key in ("camera_matrix", "distortion_coefficients", "projection_matrix"):
        assert all(isinstance(v, float) for v in ros[key]["data"]), key
    assert np.array_equal(np.array(ros["camera_matrix"]["data"]).reshape(3, 3), k)
    assert np.array_equal(np.array(ros["distortion_coefficients"]["data"]), dist)
    # OpenCV's own YAML, read by PyYAML past its %YAML:1.0 header and tags.
    body = (tmp_path / "out" / "opencv.yaml").read_text().split("---\n", 1)[1]
    cv = yaml.safe_load(body.replace("!!opencv-matrix", ""))
    assert all(isinstance(v, float) for v in cv["camera_matrix"]["data"])
    assert isinstance(cv["max_residual_px"], float)
    fs = cv2.FileStorage(str(tmp_path / "out" / "opencv.yaml"), cv2.FILE_STORAGE_READ)
    assert np.array_equal(fs.getNode("camera_matrix").mat(), k)
    fs.release()


def test_an_orthographic_camera_is_refused_naming_the_file_and_key(host_sim, scenes, tmp_path):
    text = (scenes / "standard.toml").read_text().replace(
        "[camera]\n", '[camera]\nmodel = "orthographic"\northographic_scale = 0.05\n', 1)
    f = tmp_path / "ortho.toml"
    f.write_text(text)
    r = export(host_sim, f, tmp_path / "out")
    assert r.returncode != 0
    assert "ortho.toml" in r.stderr and "camera.model" in r.stderr, r.stderr
    assert not (tmp_path / "out" / "opencv.yaml").exists()
    with pytest.raises(hilcam.SceneError) as e:
        hilcam.Scene.from_toml(f).opencv()
    assert e.value.field == "camera.model"
