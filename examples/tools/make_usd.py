"""Write examples/usd/catapult.usda: a USD stage with physics (the UsdPhysics schema), authored
with usd-core's schema classes as Omniverse or Isaac Sim would write it: Y up, centimetres,
kilograms. ``python examples/tools/make_usd.py``; edit this script, not the stage.

What is in it: a see-saw plank on a revolute joint (limits +-20 deg) over a fulcrum, a rubber
ball resting on one end, a 60 kg crate falling onto the other from 1.2 m: the ball is thrown
2.5 m up, falls back onto the plank and rolls away. Beside it, a hammer (a capsule handle and a
ball head: one rigid body of two colliders) held level by a revolute joint to the world swings
down through a stack of three crates.
"""

from __future__ import annotations

from pathlib import Path

from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade

OUT = Path(__file__).resolve().parents[1] / "usd" / "catapult.usda"


def material(stage, path, friction, restitution, density=None):
    m = UsdShade.Material.Define(stage, path)
    api = UsdPhysics.MaterialAPI.Apply(m.GetPrim())
    api.CreateStaticFrictionAttr(friction)
    api.CreateDynamicFrictionAttr(friction)
    api.CreateRestitutionAttr(restitution)
    if density is not None:
        api.CreateDensityAttr(density)
    return m


def bind(prim, mat):
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(mat, UsdShade.Tokens.weakerThanDescendants, "physics")


def box(stage, path, size, at, mass=None, body=True, mat=None):
    """A cube of side 1 scaled to ``size`` (cm) at ``at`` (cm)."""
    c = UsdGeom.Cube.Define(stage, path)
    c.GetSizeAttr().Set(1.0)
    c.AddTranslateOp().Set(Gf.Vec3d(*at))
    c.AddScaleOp().Set(Gf.Vec3f(*size))
    UsdPhysics.CollisionAPI.Apply(c.GetPrim())
    if body:
        UsdPhysics.RigidBodyAPI.Apply(c.GetPrim())
    if mass is not None:
        UsdPhysics.MassAPI.Apply(c.GetPrim()).CreateMassAttr(mass)
    if mat is not None:
        bind(c.GetPrim(), mat)
    return c.GetPrim()


def main():
    OUT.parent.mkdir(parents=True, exist_ok=True)
    stage = Usd.Stage.CreateNew(str(OUT))
    stage.SetMetadata("comment", "written by examples/tools/make_usd.py: a see-saw catapult and a hammer "
                      "(UsdPhysics), Y up, centimetres")
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    UsdPhysics.Scene.Define(stage, "/World/physicsScene")  # gravity: the schema's default, 9.81 m/s^2 down y

    wood = material(stage, "/World/Looks/wood", 0.6, 0.1, density=0.0006)  # 600 kg/m^3 in kg/cm^3
    rubber = material(stage, "/World/Looks/rubber", 0.8, 0.5)
    box(stage, "/World/ground", (1200, 20, 400), (0, -10, 0), body=False, mat=wood)
    box(stage, "/World/fulcrum", (20, 24, 40), (0, 12, 0), body=False, mat=wood)

    # the see-saw: a 3 m plank pivoting 30 cm up, about z (horizontal in a Y-up stage)
    plank = box(stage, "/World/plank", (300, 6, 40), (0, 33, 0), mass=12.0, mat=wood)
    hinge = UsdPhysics.RevoluteJoint.Define(stage, "/World/plank_hinge")
    hinge.CreateBody1Rel().SetTargets([plank.GetPath()])
    hinge.CreateAxisAttr("Z")
    hinge.CreateLocalPos0Attr(Gf.Vec3f(0, 30, 0))
    hinge.CreateLocalPos1Attr(Gf.Vec3f(0, -3.0 / 6.0, 0))  # the plank's underside (its local frame is scaled)
    hinge.CreateLowerLimitAttr(-20.0)
    hinge.CreateUpperLimitAttr(20.0)
    # level at the start: the crate's landing throws the ball
    ball = UsdGeom.Sphere.Define(stage, "/World/ball")
    ball.GetRadiusAttr().Set(10.0)
    ball.AddTranslateOp().Set(Gf.Vec3d(-135, 46, 0))
    UsdPhysics.CollisionAPI.Apply(ball.GetPrim())
    UsdPhysics.RigidBodyAPI.Apply(ball.GetPrim())
    UsdPhysics.MassAPI.Apply(ball.GetPrim()).CreateMassAttr(1.0)
    bind(ball.GetPrim(), rubber)
    box(stage, "/World/crate", (40, 40, 40), (125, 160, 0), mass=60.0, mat=wood)

    # the hammer: handle and head, one body; hinged at its top end to the world, held level
    hammer = UsdGeom.Xform.Define(stage, "/World/hammer")
    hammer.AddTranslateOp().Set(Gf.Vec3d(350, 140, 0))
    UsdPhysics.RigidBodyAPI.Apply(hammer.GetPrim())
    handle = UsdGeom.Capsule.Define(stage, "/World/hammer/handle")
    handle.GetRadiusAttr().Set(3.0)
    handle.GetHeightAttr().Set(100.0)
    handle.GetAxisAttr().Set("X")
    handle.AddTranslateOp().Set(Gf.Vec3d(-55, 0, 0))
    head = UsdGeom.Sphere.Define(stage, "/World/hammer/head")
    head.GetRadiusAttr().Set(15.0)
    head.AddTranslateOp().Set(Gf.Vec3d(-115, 0, 0))
    for part, mass in ((handle, 2.0), (head, 25.0)):
        UsdPhysics.CollisionAPI.Apply(part.GetPrim())
        UsdPhysics.MassAPI.Apply(part.GetPrim()).CreateMassAttr(mass)
    pivot = UsdPhysics.RevoluteJoint.Define(stage, "/World/hammer_pivot")
    pivot.CreateBody1Rel().SetTargets([Sdf.Path("/World/hammer")])
    pivot.CreateAxisAttr("Z")
    pivot.CreateLocalPos0Attr(Gf.Vec3f(350, 140, 0))
    pivot.CreateLocalPos1Attr(Gf.Vec3f(0, 0, 0))
    for k in range(3):  # the stack under the hammer's swing
        box(stage, f"/World/stack/crate{k}", (20, 20, 20), (320, 10 + 20 * k, 0), mat=wood)
    stage.GetRootLayer().Save()
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
