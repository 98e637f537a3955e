"""hilcam.Camera against `host-sim camera` over a pty link: commands,
refusals, frames with their truth, the same pixels as a host render."""

import numpy as np
import pytest

import hilcam


def open_camera(path):
    # The camera opens its end after it starts.
    return hilcam.Camera.when_ready(path)


def test_the_camera_obeys_and_its_frames_match_a_host_render(camera_link, scenes):
    scene = hilcam.Scene.from_toml(scenes / "standard.toml")
    with open_camera(camera_link) as cam:
        d = cam.describe()
        assert (d["width"], d["height"]) == scene.size
        assert d["scenes"] == 1
        R, T = scene.pose
        poses = [T + np.array([dx, 0.0, 0.0]) for dx in (0.0, 0.02, -0.03)]
        for k, t in enumerate(poses):
            seq = cam.set_pose(R, t)
            trig = cam.trigger(1)
            assert trig == seq + 1
            (frame,) = list(cam.frames(timeout=10, count=1))
            assert frame.truth["command"] == trig
            # Enough to render it again: the lens and the projection too.
            assert abs(frame.truth["focus_distance"] - 3.0) < 1e-9
            assert abs(frame.truth["aperture"] - 2.4e-3 / 2.0) < 1e-9
            assert frame.truth["model_scale"] == 0.0
            assert np.allclose(frame.truth["T"], t, atol=1e-6)
            scene.set_pose(R, t)
            host = scene.render(frame_id=frame.frame_id)
            assert np.array_equal(frame.image, host.image), f"pose {k}"
            assert np.array_equal(frame.outside, host.outside), f"pose {k}"


def test_refusals_raise_with_the_reason_and_field_and_change_nothing(camera_link, scenes):
    with open_camera(camera_link) as cam:
        with pytest.raises(hilcam.Refused) as e:
            cam.set_exposure(-5.0)
        _, command, reason, field = e.value.args
        assert (command, reason) == ("SetExposure", "Invalid")
        assert field == "exposure.k"
        with pytest.raises(hilcam.Refused) as e:
            cam.select_scene(7)
        assert e.value.args[3].endswith("id"), e.value.args
        # Still answering, still showing its scene.
        assert cam.describe()["scene_id"] == 0
        cam.trigger(1)
        assert len(list(cam.frames(timeout=10, count=1))) == 1


def test_a_scene_sent_as_data_is_shown(camera_link, scenes):
    other = hilcam.Scene.from_toml(scenes / "shallow-target.toml")
    with open_camera(camera_link) as cam:
        sid = cam.load_scene(other)
        assert sid == 1
        assert (cam.describe()["width"], cam.describe()["height"]) == other.size
        cam.trigger(1)
        (frame,) = list(cam.frames(timeout=20, count=1))
        assert np.array_equal(frame.image, other.render(frame_id=frame.frame_id).image)


def test_a_host_that_stops_reading_does_not_end_the_camera(camera_session):
    with open_camera(camera_session.path) as cam:
        cam.trigger(6)
        # Six 160x120 frames are 117 kB: far more than a pty buffers. The
        # camera waits for the host to read again.
        camera_session.link.pause(1.5)
        frames = list(cam.frames(timeout=20, count=6))
        assert len(frames) == 6
        assert len({f.frame_id for f in frames}) == 6
        assert camera_session.proc.poll() is None
        assert cam.describe()["pending"] == 0


def test_a_hang_up_after_every_frame_ends_the_session_with_exit_0(host_sim, scenes):
    from conftest import CameraSession

    for k in range(5):
        s = CameraSession(host_sim, scenes / "standard.toml")
        try:
            with open_camera(s.path) as cam:
                cam.trigger(2)
                assert len(list(cam.frames(timeout=20, count=2))) == 2
            code, out, err = s.hang_up()
            assert code == 0, f"session {k}: exit {code}: {err}"
            assert "2 frames sent" in out, out
        finally:
            s.close()
