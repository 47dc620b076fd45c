"""Opens a hairkit USD export with Pixar's USD library and checks what Unreal's and Blender's
importers read: the prim's type, every array's count against its interpolation (USD's
validators do not check counts), the stage metadata and the groom schema and properties.

Usage: python check_usd.py FILE.usda CURVES POINTS
Prints one line per check; exits non-zero with the reason on the first failure."""
import sys

from pxr import Usd, UsdGeom

path, curves, points = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])


def check(ok, what):
    if not ok:
        sys.exit(f"{path}: {what}")
    print(f"ok: {what}")


stage = Usd.Stage.Open(path)
check(stage is not None, "the stage opens")
check(UsdGeom.GetStageUpAxis(stage) == "Y", "upAxis is Y")
check(UsdGeom.GetStageMetersPerUnit(stage) == 1.0, "metersPerUnit is 1")
check(stage.GetDefaultPrim().GetPath() == "/Groom", "the default prim is /Groom")
groom = stage.GetPrimAtPath("/Groom")
check("GroomAPI" in groom.GetMetadata("apiSchemas").GetAddedOrExplicitItems(), "GroomAPI is applied to /Groom")
check(groom.GetAttribute("userProperties:groom_version_major").Get() == 1, "groom_version_major is 1")
check(groom.GetAttribute("userProperties:groom_version_minor").Get() == 5, "groom_version_minor is 5")
prim = stage.GetPrimAtPath("/Groom/Strands")
check(prim.GetTypeName() == "BasisCurves", "/Groom/Strands is BasisCurves")
curves_schema = UsdGeom.BasisCurves(prim)
check(curves_schema.GetTypeAttr().Get() == "linear", "the curves are linear")
counts = curves_schema.GetCurveVertexCountsAttr().Get()
check(len(counts) == curves, f"{curves} curves")
check(sum(counts) == points, f"{points} points in the counts")
check(max(counts) <= 255, "at most 255 points per curve (Unreal)")
check(len(curves_schema.GetPointsAttr().Get()) == points, "one point per vertex")
widths = curves_schema.GetWidthsAttr().Get()
check(curves_schema.GetWidthsInterpolation() == "vertex" and len(widths) == points, "one width per vertex")
check(all(w > 0 for w in widths), "every width is positive")
expected = {"uniform": curves, "vertex": points, "constant": 1}
primvars = {pv.GetPrimvarName(): pv for pv in UsdGeom.PrimvarsAPI(prim).GetPrimvars() if pv.HasValue()}
for name, interpolation in [
    ("groom_id", "uniform"),
    ("groom_group_id", "uniform"),
    ("groom_guide", "uniform"),
    ("groom_root_uv", "uniform"),
    ("groom_color", "vertex"),
    ("displayColor", "constant"),
]:
    check(name in primvars, f"primvar {name} exists")
    pv = primvars[name]
    check(pv.GetInterpolation() == interpolation, f"{name} is {interpolation}")
    check(len(pv.Get()) == expected[interpolation], f"{name} has {expected[interpolation]} values")
ids = primvars["groom_id"].Get()
check(len(set(ids)) == curves, "groom_id is unique per curve")
uvs = primvars["groom_root_uv"].Get()
check(all(0.0 <= u <= 1.0 and 0.0 <= v <= 1.0 for u, v in uvs), "root uvs lie in [0, 1]")
