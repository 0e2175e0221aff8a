"""The capture-degradation model: each fault does what it says, scaled as the sensor's
parameters say; presets and sensor JSON files load (bad ones are refused, naming the field);
and the depth cleanup undoes most of it while leaving an exact capture alone."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from pipeline.capture import Camera, Capture, Frame
from pipeline.depth_cleanup import clean_capture, clean_depth, noise_level
from pipeline.procedural import generate
from pipeline.render import render_object
from pipeline.sensors import PRESETS, SensorModel, degrade, degrade_depth, load_sensor
from real2code_export.errors import FormatError, InputError


def _wall(z: float, size: int = 64) -> Frame:
    """A frame looking straight at a flat wall ``z`` metres away."""
    camera = Camera(60.0, 60.0, size / 2, size / 2, size, size)
    rgb = np.full((size, size, 3), 128, np.uint8)
    return Frame(camera, np.eye(4), rgb, np.full((size, size), z, np.float32))


def test_depth_noise_grows_with_range():
    sensor = SensorModel(noise_a=0.001, noise_b=0.002, noise_z0=0.4)
    rng = np.random.default_rng(0)
    spread = {z: float(np.std(degrade_depth(_wall(z), sensor, rng) - z)) for z in (0.5, 3.0)}
    assert spread[0.5] == pytest.approx(0.001 + 0.002 * 0.01, rel=0.1)
    assert spread[3.0] == pytest.approx(0.001 + 0.002 * 2.6 ** 2, rel=0.1)


def test_missing_pixels_quantisation_and_range():
    rng = np.random.default_rng(1)
    depth = degrade_depth(_wall(1.0), SensorModel(missing=0.1), rng)
    assert (depth == 0).mean() == pytest.approx(0.1, abs=0.02)
    depth = degrade_depth(_wall(1.2345), SensorModel(noise_a=0.003, depth_step=0.01), rng)
    assert np.allclose(depth / 0.01, np.round(depth / 0.01), atol=1e-3)
    assert not degrade_depth(_wall(6.0), SensorModel(max_range=5.0), rng).any()


def test_flying_pixels_lie_between_the_surfaces():
    frame = _wall(2.0)
    frame.depth[:, 32:] = 1.0  # a step: near surface on the right
    depth = degrade_depth(frame, SensorModel(flying=1.0), np.random.default_rng(2))
    between = (depth > 1.0 + 1e-6) & (depth < 2.0 - 1e-6)
    assert between.any() and set(np.nonzero(between)[1]) <= {32}  # on the edge only


def test_presets_degrade_a_render_and_leave_masks_and_clean_alone():
    cap = render_object(generate("box", 2, 0), views=3, width=64, height=64, seed=0)
    assert degrade(cap, PRESETS["clean"]).frames[0] is cap.frames[0]
    for name in ("phone-lidar", "structured-light", "time-of-flight"):
        noisy = degrade(cap, PRESETS[name], seed=3)
        assert noisy.extra["sensor"]["name"] == name
        for a, b in zip(cap.frames, noisy.frames, strict=True):
            assert np.array_equal(a.mask, b.mask)
            assert not np.array_equal(a.depth, b.depth)
            assert not np.allclose(a.camera_to_world, b.camera_to_world)
            assert (b.depth > 0).sum() < (a.depth > 0).sum()  # pixels went missing


def test_sensor_json_files(tmp_path):
    good = tmp_path / "my_sensor.json"
    good.write_text(json.dumps({"noise_a": 0.002, "missing": 0.05}))
    sensor = load_sensor(good)
    assert sensor == replace(SensorModel(), name="my_sensor", noise_a=0.002, missing=0.05)
    assert load_sensor("phone-lidar") is PRESETS["phone-lidar"]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"noise": 0.002}))
    with pytest.raises(FormatError, match="noise.*unknown sensor field"):
        load_sensor(bad)
    bad.write_text(json.dumps({"missing": -1}))
    with pytest.raises(FormatError, match="missing.*>= 0"):
        load_sensor(bad)
    with pytest.raises(InputError, match="unknown capture preset"):
        load_sensor("kinect")


def test_cleanup_leaves_an_exact_capture_alone_and_undoes_noise():
    obj = generate("storage_furniture", 4, 2)
    cap = render_object(obj, views=12, width=192, height=192, seed=2)
    same, summary = clean_capture(cap)
    assert summary["dropped"] == summary["filled"] == 0
    assert all(np.array_equal(a.depth, b.depth) and np.array_equal(a.camera_to_world,
               b.camera_to_world) for a, b in zip(cap.frames, same.frames, strict=True))
    noisy = degrade(cap, PRESETS["phone-lidar"], seed=1)
    assert noise_level(noisy.frames[0].depth) > 10 * noise_level(cap.frames[0].depth)
    cleaned, summary = clean_capture(noisy)
    assert summary["dropped"] > 0 and summary["filled"] > 0
    assert clean_capture(cleaned)[0] is cleaned  # cleaned once, whoever asks again
    moved = [np.linalg.norm(a.camera_to_world[:3, 3] - b.camera_to_world[:3, 3])
             for a, b in zip(noisy.frames, cleaned.frames, strict=True)]
    assert summary["pose_moves_m"] == pytest.approx(moved, abs=1e-4)  # what the poses moved

    def depth_error(capture):
        errors = [np.abs(a.depth - b.depth)[(a.depth > 0) & (b.depth > 0)]
                  for a, b in zip(cap.frames, capture.frames, strict=True)]
        return np.median(np.concatenate(errors)), np.percentile(np.concatenate(errors), 99)

    def surface_shift(capture):  # how far the poses move the true surface, mean over views
        shifts = []
        for a, b in zip(cap.frames, capture.frames, strict=True):
            local = (a.camera.pixel_directions() * a.depth[..., None])[a.depth > 0]
            shifts.append(np.linalg.norm(local @ (a.camera_to_world[:3, :3]
                                                  - b.camera_to_world[:3, :3]).T
                                         + a.camera_to_world[:3, 3] - b.camera_to_world[:3, 3],
                                         axis=1).mean())
        return float(np.mean(shifts))

    (median_before, tail_before), (median_after, tail_after) = (depth_error(noisy),
                                                                 depth_error(cleaned))
    assert median_after < 0.6 * median_before and tail_after < 0.6 * tail_before
    assert surface_shift(cleaned) < surface_shift(noisy)


def test_clean_depth_fills_a_small_hole_in_a_noisy_wall():
    frame = _wall(1.5)
    depth = degrade_depth(frame, SensorModel(noise_a=0.003), np.random.default_rng(4))
    depth[30:32, 30:32] = 0.0
    out, note = clean_depth(depth)
    assert note["filled"] >= 4 and (out[30:32, 30:32] > 0).all()
    assert np.std(out[5:-5, 5:-5] - 1.5) < 0.6 * np.std(depth[5:-5, 5:-5] - 1.5)


def test_degrade_is_seeded():
    cap = render_object(generate("box", 2, 0), views=2, width=32, height=32, seed=0)
    a, b = (degrade(cap, PRESETS["phone-lidar"], seed=5) for _ in range(2))
    assert all(np.array_equal(x.depth, y.depth) and np.array_equal(x.rgb, y.rgb)
               for x, y in zip(a.frames, b.frames, strict=True))
    assert isinstance(a, Capture)


def test_mask_network_training_views_can_come_through_a_sensor():
    from pipeline.segment.data import object_views

    obj = generate("box", 2, 3)
    clean = object_views(obj, np.random.default_rng(0), 2)
    noisy = object_views(obj, np.random.default_rng(0), 2, cameras=("ring",),
                         sensors=("time-of-flight",))
    assert len(clean) == len(noisy) == 2
    assert all(v.depth.shape == w.depth.shape for v, w in zip(clean, noisy, strict=True))
    assert not any(np.array_equal(v.depth, w.depth) for v, w in zip(clean, noisy, strict=True))
