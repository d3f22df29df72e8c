"""Open a usda with Pixar's USD (pip install usd-core) and print its BasisCurves, for
tests/it/formats.rs: curve count, vertex counts, points and widths, floats as repr (exact)."""
import sys

from pxr import Usd, UsdGeom

stage = Usd.Stage.Open(sys.argv[1])
if stage is None:
    sys.exit(f"USD could not open {sys.argv[1]}")
curves = [UsdGeom.BasisCurves(p) for p in stage.Traverse() if p.IsA(UsdGeom.BasisCurves)]
print("curves", len(curves))
c = curves[0]
print("counts", *c.GetCurveVertexCountsAttr().Get())
print("points", *(repr(v) for p in c.GetPointsAttr().Get() for v in p))
print("widths", *(repr(w) for w in c.GetWidthsAttr().Get()))
print("interpolation", c.GetWidthsInterpolation())
