"""Mass properties of object types from their geometry, through Drake's CalcSpatialInertia (uniform density)."""
import numpy as np
import pytest

pytest.importorskip("pydrake")

from bridge.errors import ObjectDatabaseError  # noqa: E402
from bridge.odb import load_object_database  # noqa: E402
from bridge.sim.shapes import mass_properties  # noqa: E402


def test_mass_properties_from_geometry(odb_copy):
    odb = load_object_database(odb_copy)
    big = mass_properties(odb, "big_box")  # 1 kg, 0.1 x 0.1 x 0.25 m
    assert big.mass == pytest.approx(1.0)
    assert big.inertia[0, 0] == pytest.approx(1.0 / 12 * (0.1**2 + 0.25**2))
    assert big.inertia[2, 2] == pytest.approx(1.0 / 12 * (0.1**2 + 0.1**2))
    bottle = mass_properties(odb, "bottle")  # cylinder r 0.035, 0.24 long, 0.5 kg
    assert bottle.inertia[2, 2] == pytest.approx(0.5 * 0.5 * 0.035**2)


def test_mit_shapes_from_dataset_meshes(odb_copy, mit_push_root):
    odb = load_object_database(odb_copy, datasets={"mit-push": mit_push_root})
    rect1 = mass_properties(odb, "rect1")
    # 90 x 90 x 12.8 mm of steel at 7950 kg/m^3; the dataset's README weighs it at 0.837 kg
    assert rect1.mass == pytest.approx(0.837, rel=0.03)
    assert np.linalg.norm(rect1.com) < 1e-4


def test_dataset_mesh_without_root_fails_only_when_used(odb_copy):
    # an unknown dataset: the database still loads; the type fails with advice once its mass is needed
    (odb_copy / "types" / "extra.yaml").write_text(
        'ghost: {parent: mit_shape, geometry: {shape: mesh, mesh: "dataset://other-set/x.obj"}}\n')
    odb = load_object_database(odb_copy)
    with pytest.raises(ObjectDatabaseError, match=r"--dataset other-set=PATH or set BRIDGE_OTHER_SET"):
        mass_properties(odb, "ghost")
