"""A real camera's calibration as a scene's lens (docs/scenes.md, "Your own
lens"): the files OpenCV and ROS write, imaged as OpenCV projects, and
exported back as the same numbers."""

import numpy as np
import pytest

import hilcam

cv2 = pytest.importorskip("cv2")
yaml = pytest.importorskip("yaml")

K = np.array([[600.0, 0.0, 318.7], [0.0, 602.5, 241.3], [0.0, 0.0, 1.0]])
K_FISHEYE = np.array([[300.0, 0.0, 320.2], [0.0, 300.5, 239.6], [0.0, 0.0, 1.0]])
# (name, file, camera matrix, coefficients, fisheye)
CASES = [
    # plumb_bob with tangential terms, as cv2.FileStorage writes YAML.
    ("plumb_bob", "cam.yaml", K, [-0.28, 0.09, 1.2e-3, -7e-4, -0.015], False),
    # The rational model's 8 terms, as cv2.FileStorage writes XML.
    ("rational", "cam.xml", K, [0.9, 0.25, 8e-4, -5e-4, 0.004, 1.25, 0.42, 0.03], False),
    # 12 terms: rational and thin prism.
    ("thin_prism", "cam.yml", K, [-0.2, 0.05, 5e-4, 3e-4, 0.0, 0.1, 0.02, 0.0, 1e-3, -2e-4, 5e-4, 1e-4], False),
    # OpenCV's fisheye as a ROS CameraInfo (equidistant) YAML.
    ("fisheye", "ros.yaml", K_FISHEYE, [0.05, -0.01, 0.003, -0.0008], True),
]

SCENE = """name = "{name}"
[output]
format = "gray8"
exposure = 800.0
[camera]
calibration = "{file}"
focal_length = 3.6e-3
f_number = 2.0
focus_distance = 3.0
tolerable_blur = 6e-6
pose = {{ eye = [0.0, 1.2, -3.0], target = [0.0, 0.4, 0.0], up = [0.0, 1.0, 0.0] }}
[[materials]]
name = "floor"
albedo = 0.6
[[lights]]
kind = "point"
position = [2.0, 3.0, -2.0]
intensity = 50.0
[[primitives]]
kind = "plane"
material = "floor"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
"""


def write_calibration(path, k, d, fisheye):
    if path.name == "ros.yaml":
        ros = {
            "image_width": 640,
            "image_height": 480,
            "camera_name": "lens",
            "camera_matrix": {"rows": 3, "cols": 3, "data": k.flatten().tolist()},
            "distortion_model": "equidistant" if fisheye else "plumb_bob",
            "distortion_coefficients": {"rows": 1, "cols": len(d), "data": list(d)},
        }
        path.write_text(yaml.safe_dump(ros))
        return
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("camera_matrix", k)
    fs.write("distortion_coefficients", np.array(d))
    fs.release()


def scene_with(tmp_path, name, file, k, d, fisheye):
    write_calibration(tmp_path / file, k, d, fisheye)
    (tmp_path / "scene.toml").write_text(SCENE.format(name=name, file=file))
    return hilcam.Scene.from_toml(tmp_path / "scene.toml")


@pytest.mark.parametrize("name,file,k,d,fisheye", CASES, ids=[c[0] for c in CASES])
def test_each_pixel_images_where_opencv_projects_its_ray(tmp_path, name, file, k, d, fisheye):
    scene = scene_with(tmp_path, name, file, k, d, fisheye)
    assert scene.size == (640, 480)
    rays = scene.pixel_rays()
    # A grid over the whole sensor: every 4th pixel, and the last row and
    # column.
    cols = np.unique(np.r_[np.arange(0, 640, 4), 639])
    rows = np.unique(np.r_[np.arange(0, 480, 4), 479])
    jj, ii = np.meshgrid(rows, cols, indexing="ij")
    pts = rays[jj, ii].reshape(-1, 2)
    pix = np.c_[ii.ravel(), jj.ravel()].astype(float)
    inside = ~np.isnan(pts[:, 0])
    # These lenses are monotonic over the sensor: every pixel images.
    assert inside.all(), f"{(~inside).sum()} pixels outside the lens field"
    obj = np.c_[pts, np.ones(len(pts))].reshape(-1, 1, 3)
    zero = np.zeros(3)
    if fisheye:
        proj, _ = cv2.fisheye.projectPoints(obj, zero, zero, k, np.array(d))
    else:
        proj, _ = cv2.projectPoints(obj, zero, zero, k, np.array(d))
    err = np.abs(proj.reshape(-1, 2) - pix).max()
    print(f"{name}: max |pixel - cv2 projection| = {err:.3e} px over {len(pix)} pixels")
    assert err <= 1 / 256, err
    # host-sim export of the imported camera gives back the same numbers.
    k_out, d_out, _, _, size = scene.opencv()
    assert size == (640, 480)
    np.testing.assert_allclose(k_out, k, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(d_out.ravel(), d, rtol=1e-12, atol=0)


def test_a_lens_that_folds_flags_the_pixels_beyond_the_fold(tmp_path):
    # Strong barrel: r (1 - 0.5 r^2) stops growing at r^2 = 2/3; at f = 300
    # px the fold's image, r_d = 0.544, lies inside the 640 x 480 sensor.
    k = np.array([[300.0, 0.0, 319.5], [0.0, 300.0, 239.5], [0.0, 0.0, 1.0]])
    scene = scene_with(tmp_path, "fold", "cam.yaml", k, [-0.5, 0.0, 0.0, 0.0, 0.0], False)
    rays = scene.pixel_rays()
    j, i = np.mgrid[0:480, 0:640]
    rd = np.hypot((i - 319.5) / 300.0, (j - 239.5) / 300.0)
    fold = np.sqrt(2.0 / 3.0) * (1.0 - 1.0 / 3.0)
    outside = np.isnan(rays[..., 0])
    assert outside[rd > fold * 1.001].all()
    assert not outside[rd < fold * 0.999].any()
    # The frame flags those, and pixels whose area reaches past the fold
    # (within half a diagonal of it).
    frame = scene.render()
    assert frame.outside[outside].all()
    extra = frame.outside & ~outside
    assert (rd[extra] > fold - np.sqrt(0.5) / 300.0).all()


@pytest.mark.parametrize(
    "edit,message",
    [
        (lambda k, d: (k * np.array([[1, 0, 1], [1, 1, 1], [1, 1, 1]]) + np.array([[0, 2.0, 0], [0, 0, 0], [0, 0, 0]]), d), "skew"),
        (lambda k, d: (k, d + [0.1]), "6 coefficients"),
        (lambda k, d: (k, d[:4] + [0.0] * 10), None),
        (lambda k, d: (k, d[:4] + [0.0] * 8 + [0.01, 0.0]), "tilted"),
    ],
    ids=["skew", "six-terms", "fourteen-untilted", "tilted"],
)
def test_a_calibration_the_renderer_cannot_image_is_refused_naming_the_key(tmp_path, edit, message):
    k, d = edit(K.copy(), [-0.28, 0.09, 1.2e-3, -7e-4, -0.015])
    if message is None:
        scene_with(tmp_path, "ok", "cam.yaml", k, d, False)
        return
    with pytest.raises(hilcam.SceneError) as e:
        scene_with(tmp_path, "bad", "cam.yaml", k, d, False)
    assert e.value.field.startswith("camera."), str(e.value)
    assert message in str(e.value), str(e.value)
