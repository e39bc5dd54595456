import numpy as np
import pytest

import exactgrasp as eg
from exactgrasp import backends as registry
from exactgrasp.backends.base import repeated_poses
from exactgrasp.descriptor import DescriptorError
from tests.conftest import box_grasp


class ShiftBackend(eg.Backend):
    """Volume = squared x-translation of the pose: known numbers without geometry."""

    name = "shift"

    def __init__(self, scale: float = 1.0):
        self.scale = scale

    @property
    def params(self):
        return {"scale": self.scale}

    def volumes(self, grasp, poses):
        poses = registry.check_poses(poses)
        return self.scale * poses[..., 0, 3] ** 2


@pytest.fixture
def grasp():
    return box_grasp()


@pytest.fixture(autouse=True)
def _shift_backend():
    eg.register_backend("shift", ShiftBackend)
    yield
    registry.unregister_backend("shift")


def test_descriptor_values_are_volume_over_hand_volume(grasp):
    sampler = eg.PathSampler(3, 2, 2, n_steps=4)
    d = eg.compute_descriptor(grasp, sampler, backend=ShiftBackend(scale=2.0))
    expected = 2.0 * sampler.poses()[..., 0, 3] ** 2 / grasp.canonical_hand_volume
    # A pose equal to an earlier one to rounding takes that one's value.
    np.testing.assert_allclose(d.values, expected, rtol=1e-12, atol=1e-28)
    assert d.shape == (sampler.n_paths, 4)
    meta = d.metadata
    assert meta["backend"] == "shift" and meta["backend_params"] == {"scale": 2.0}
    assert meta["sampler"] == sampler.params
    assert meta["version"] == eg.__version__
    assert meta["object_hash"] == grasp.object.hash
    assert meta["hand_volume_m3"] == pytest.approx(0.1 * 0.1 * 0.02)


def test_save_load_round_trip(tmp_path, grasp):
    d = eg.compute_descriptor(grasp, eg.PathSampler(2, 1, 2, n_steps=3), backend="shift")
    loaded = eg.Descriptor.load(d.save(tmp_path / "d.npz"))
    assert np.array_equal(loaded.values, d.values)
    assert loaded.metadata == d.metadata
    assert np.array_equal(loaded.sampler.poses(), d.sampler.poses())


def test_distances():
    a = eg.Descriptor(np.array([[0.0, 1.0, 3.0], [0.0, 0.0, 0.0]]))
    b = eg.Descriptor(np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]))
    assert eg.distance(a, b, "l2") == pytest.approx(np.sqrt(1 + 9 + 3))
    # step differences: a -> [[1, 2], [0, 0]], b -> [[0, 0], [0, 0]]
    assert eg.distance(a, b, "l2_diff") == pytest.approx(np.sqrt(5))
    m = eg.pairwise_distances([a, b, a])
    np.testing.assert_allclose(
        m, [[0, np.sqrt(13), 0], [np.sqrt(13), 0, np.sqrt(13)], [0, np.sqrt(13), 0]]
    )
    with pytest.raises(DescriptorError, match="distance kind 'l1' is unknown"):
        eg.distance(a, b, "l1")
    with pytest.raises(DescriptorError, match="not comparable"):
        eg.distance(a, eg.Descriptor(np.zeros((3, 3))))


def test_descriptor_refuses_nan_and_bad_files(tmp_path):
    with pytest.raises(DescriptorError, match="NaN or infinite"):
        eg.Descriptor(np.array([[np.nan]]))
    with pytest.raises(DescriptorError, match="no such descriptor file"):
        eg.Descriptor.load(tmp_path / "x.npz")
    np.savez(tmp_path / "other.npz", a=np.zeros(2))
    with pytest.raises(DescriptorError, match="not a descriptor file"):
        eg.Descriptor.load(tmp_path / "other.npz")


def test_nan_volumes_from_a_backend_are_an_error(grasp):
    class NanBackend(ShiftBackend):
        name = "nan"

        def volumes(self, grasp, poses):
            out = super().volumes(grasp, poses)
            out.flat[0] = np.nan
            return out

    with pytest.raises(DescriptorError, match=r"returned \d+ invalid \(NaN or negative\)"):
        eg.compute_descriptor(grasp, eg.PathSampler(2, 1, 2, n_steps=3), backend=NanBackend())


def test_negative_volumes_from_a_backend_are_an_error(grasp):
    class NegativeBackend(ShiftBackend):
        name = "negative"

        def volumes(self, grasp, poses):
            out = super().volumes(grasp, poses)
            out.flat[[1, 4]] = -1e-12
            return out

    with pytest.raises(
        DescriptorError,
        match=r"^backend 'negative' returned 2 invalid \(NaN or negative\) volumes for grasp 'g'",
    ):
        eg.compute_descriptor(grasp, eg.PathSampler(2, 1, 2, n_steps=3), backend=NegativeBackend())


def test_descriptors_of_different_samplers_of_one_shape_are_not_comparable(grasp):
    # Same (n_paths, n_steps), other paths: the values of row p do not describe the same path.
    a = eg.compute_descriptor(grasp, eg.PathSampler(3, 2, 2, n_steps=4), backend="shift")
    other = eg.PathSampler(3, 2, 2, n_steps=4, amounts=[-0.25, 0.25])
    b = eg.compute_descriptor(grasp, other, backend="shift")
    assert a.shape == b.shape
    for call in (lambda: eg.distance(a, b), lambda: eg.pairwise_distances([a, b])):
        with pytest.raises(
            DescriptorError, match=r"come from different samplers .* not comparable"
        ):
            call()
    assert eg.distance(a, a) == 0.0


def test_metadata_records_the_frame_convention(grasp):
    d = eg.compute_descriptor(grasp, eg.PathSampler(2, 1, 2, n_steps=3), backend="shift")
    assert d.metadata["frame"] == grasp.frame.to_dict()
    assert d.metadata["frame"]["scale"] == pytest.approx(2 / 0.08)


def test_registry_errors():
    with pytest.raises(eg.BackendError, match="unknown backend 'nope'; available:"):
        eg.get_backend("nope")
    with pytest.raises(eg.BackendError, match="bad parameters"):
        eg.get_backend("shift", resolution=3)
    with pytest.raises(eg.BackendError, match="set parameters when constructing"):
        eg.get_backend(ShiftBackend(), scale=2)
    with pytest.raises(eg.BackendError, match="not a Backend subclass"):
        eg.register_backend("x", dict)
    with pytest.raises(eg.BackendError, match="not a 'module:Class' path"):
        eg.register_backend("x", "tests.test_descriptor")
    eg.register_backend(
        "shift2",
        "tests.test_descriptor:ShiftBackend",
        requires=[("no_such_module_xyz", "xyz-pkg", "exact")],
    )
    try:
        with pytest.raises(
            eg.MissingDependencyError, match=r"pip install xyz-pkg.*exactgrasp\[exact\]"
        ):
            eg.get_backend("shift2")
        assert "shift2" not in eg.available_backends()
    finally:
        registry.unregister_backend("shift2")
    assert "shift2" not in registry.registry.BACKENDS


def test_register_by_path_then_unregister_restores_the_builtin():
    eg.register_backend("voxel", "tests.test_descriptor:ShiftBackend")
    try:
        assert eg.get_backend("voxel").name == "shift"
    finally:
        registry.unregister_backend("voxel")
    assert eg.get_backend("voxel").name == "voxel"
    assert registry.registry.BACKENDS["voxel"] == registry.registry.BUILTIN_BACKENDS["voxel"]


def test_shared_backend_is_one_instance_per_name_and_parameters():
    first = registry.shared_backend("shift", scale=2.0)
    assert registry.shared_backend("shift", scale=2.0) is first
    assert registry.shared_backend("shift", scale=3.0) is not first
    assert registry.shared_backend(first) is first
    # Registering a backend again drops the shared instances built from the old one.
    eg.register_backend("shift", ShiftBackend)
    assert registry.shared_backend("shift", scale=2.0) is not first


def test_entry_point_group_lists_builtins():
    from importlib.metadata import entry_points

    names = {ep.name for ep in entry_points(group="exactgrasp.backends")}
    assert {"voxel", "exact"} <= names
    assert "shift" in eg.available_backends()


def test_compare_backends_table_and_summary(grasp, tmp_path):
    sampler = eg.PathSampler(3, 2, 2, n_steps=4)
    result = eg.compare_backends(grasp, sampler, backends=(ShiftBackend(3.0), ShiftBackend(1.0)))
    table = result.table
    assert len(table["path"]) == sampler.n_poses
    ref = table["value_shift1"]
    est = table["value_shift0"]
    np.testing.assert_allclose(est, 3 * ref)
    s = result.summary["shift0"]
    compared = ref > 1e-4
    assert s["n_compared"] == int(compared.sum())
    assert s["median_abs_rel"] == pytest.approx(2.0)
    assert s["max_abs_rel"] == pytest.approx(2.0)
    assert s["correlation"] == pytest.approx(1.0)
    assert s["mean_signed_error"] == pytest.approx(2 * ref.mean())
    assert "median|rel|" in result.summary_text()
    from exactgrasp.compare import write_table

    csv_path = write_table(table, tmp_path / "t.csv")
    lines = csv_path.read_text().splitlines()
    assert len(lines) == sampler.n_poses + 1 and lines[0].startswith("path,step,t,kind")
    import pyarrow.parquet as pq

    parquet = pq.read_table(write_table(table, tmp_path / "t.parquet"))
    assert parquet.num_rows == sampler.n_poses
    np.testing.assert_array_equal(parquet.column("value_shift0").to_numpy(), est)


class SlowBackend(ShiftBackend):
    """`ShiftBackend` whose calls take 0.3 s more."""

    name = "slow"

    def volumes(self, grasp, poses):
        import time

        time.sleep(0.3)
        return super().volumes(grasp, poses)


def test_seconds_are_the_whole_call_and_old_compile_seconds_are_read(grasp, tmp_path):
    from exactgrasp.cli.common import timing

    sampler = eg.PathSampler(3, 2, 2, n_steps=4)
    d = eg.compute_descriptor(grasp, sampler, backend=SlowBackend())
    assert 0.3 <= d.metadata["seconds"] < 2.0
    assert "compile_seconds" not in d.metadata  # nothing compiles at a first call
    assert timing({"seconds": 1.25}) == "in 1.25 s"
    result = eg.compare_backends(grasp, sampler, backends=[SlowBackend(), ShiftBackend()])
    assert 0.3 <= result.seconds["slow"] < 2.0 and result.seconds["shift"] < 0.3
    assert "compil" not in result.summary_text()
    # A file written when the first call compiled kernels: its record is read as written.
    old = eg.Descriptor(d.values, {**d.metadata, "seconds": 10.0, "compile_seconds": 7.5})
    back = eg.Descriptor.load(old.save(tmp_path / "old.npz"))
    assert back.metadata["compile_seconds"] == 7.5 and back.metadata["seconds"] == 10.0
    np.testing.assert_array_equal(back.values, d.values)


def test_the_progress_bar_says_why_it_counts_fewer_poses(grasp, capsys):
    """The balanced preset repeats poses; the bar counts those computed, and says so."""
    sampler = eg.PathSampler.preset("balanced", n_steps=3)
    eg.compute_descriptor(grasp, sampler, backend="shift", progress=True)
    err = capsys.readouterr().err
    distinct = len(np.unique(repeated_poses(sampler.poses().reshape(-1, 4, 4))))
    assert distinct < sampler.n_poses == 474 * 3
    expected = f"shift poses ({distinct:,} distinct of {sampler.n_poses:,}: repeats computed once)"
    assert expected in err
