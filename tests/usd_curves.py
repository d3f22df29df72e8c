"""Write cubic and linear BasisCurves with Pixar's USD (pip install usd-core) the way Houdini,
Blender and Maya do, and print what Kami must make of them, for tests/it/usd_curves.rs.

usage: usd_curves.py mixed OUT.usda   every basis and wrap, nested transforms, metres, z up
       usd_curves.py single OUT.usda  one catmullRom groom (kept cubic by Kami)
       usd_curves.py read IN.usda     print a file's curves as USD sees them
       usd_curves.py crate IN.usda OUT    the same layer saved as OUT (.usdc or .usdz)
       usd_curves.py animated OUT.usda    a simulation cache: points time-sampled at time
                                          codes 1 to 12 (30 per second), every 3rd code
                                          authored, the rest interpolated by USD
OUT may end in .usdc (binary crate) or .usdz (the crate file packed) instead.

The expected polylines are computed here, independently of Kami: each curve's basis from
the USD spec's matrices, 8 samples a segment then the end, moved by USD's own
ComputeLocalToWorldTransform, then to Kami's space (centimetres, y up). Floats as repr."""
import math
import sys

from pxr import Gf, Sdf, Usd, UsdGeom, UsdUtils, Vt

PER_SEGMENT = 8


def weights(basis, t):
    s = 1.0 - t
    if basis == "linear":
        return [s, t]
    if basis == "bezier":
        return [s**3, 3 * t * s * s, 3 * t * t * s, t**3]
    if basis == "bspline":
        return [s**3 / 6, (3 * t**3 - 6 * t**2 + 4) / 6, (-3 * t**3 + 3 * t**2 + 3 * t + 1) / 6, t**3 / 6]
    return [
        0.5 * (-(t**3) + 2 * t * t - t),
        0.5 * (3 * t**3 - 5 * t * t + 2),
        0.5 * (-3 * t**3 + 4 * t * t + t),
        0.5 * (t**3 - t * t),
    ]


def segments(basis, wrap, n):
    if basis == "linear":
        return n if wrap == "periodic" else n - 1
    if basis == "bezier":
        return n // 3 if wrap == "periodic" else (n - 1) // 3
    return {"periodic": n, "pinned": n - 1, "nonperiodic": n - 3}[wrap]


def controls(basis, wrap, vals, s):
    """The values weighing on segment s (USD's vstep and wrap rules)."""
    n = len(vals)
    if basis == "linear":
        return [vals[s % n], vals[(s + 1) % n]]
    if basis == "bezier":
        return [vals[(3 * s + k) % n] for k in range(4)]
    if wrap == "periodic":
        return [vals[(s + k) % n] for k in range(4)]
    if wrap == "pinned":
        ext = [2 * vals[0] - vals[1]] + list(vals) + [2 * vals[-1] - vals[-2]]
        return ext[s : s + 4]
    return vals[s : s + 4]


def sample(basis, wrap, vals, varying=None):
    """A curve's samples: 8 a segment, then the end. `varying`: one value per segment end."""
    segs = segments(basis, wrap, len(vals))
    per = 1 if basis == "linear" else PER_SEGMENT  # straight pieces need no samples
    out = []
    for s in range(segs):
        for k in range(per + (1 if s == segs - 1 else 0)):
            t = k / per
            if varying is not None:
                m = len(varying)
                out.append(varying[s % m] * (1 - t) + varying[(s + 1) % m] * t)
            else:
                terms = [w * c for w, c in zip(weights(basis, t), controls(basis, wrap, vals, s))]
                acc = terms[0]
                for x in terms[1:]:
                    acc = acc + x
                out.append(acc)
    return out


def srgb(c):
    """USD's displayColor is linear; Kami keeps colours sRGB-encoded."""
    return 12.92 * c if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055


def to_kami(p, xf, mpu, up):
    q = xf.Transform(Gf.Vec3d(*p))
    # the stage's units to centimetres, z up to y up: (x, y, z) -> (x, z, -y)
    k = mpu / 0.01
    if up == UsdGeom.Tokens.z:
        return (q[0] * k, q[2] * k, -q[1] * k)
    return (q[0] * k, q[1] * k, q[2] * k)


def curve_points(i, n, basis):
    """Control points of curve i: a wavy strand hanging down, different per curve."""
    return [
        Gf.Vec3f(0.01 * i + 0.004 * math.sin(j + i), 0.003 * math.cos(2 * j), -0.02 * j)
        for j in range(n)
    ]


CASES = [
    # basis, wrap, vertex counts, widths interpolation, transform of the prim
    ("bezier", "nonperiodic", [7, 4], "vertex", "transform"),
    ("bezier", "periodic", [6], "varying", "orient"),
    ("bspline", "nonperiodic", [5, 6], "varying", "rotateZYX"),
    ("bspline", "periodic", [4], "vertex", "pivot"),
    ("bspline", "pinned", [3, 5], "vertex", None),
    ("catmullRom", "nonperiodic", [6], "varying", "scale"),
    ("catmullRom", "periodic", [5], "vertex", "rotateY"),
    ("catmullRom", "pinned", [2, 4], "varying", "translate"),
    ("linear", "nonperiodic", [3], "vertex", None),
]


def add_op(xf, op):
    if op == "transform":
        m = Gf.Matrix4d().SetRotate(Gf.Rotation(Gf.Vec3d(1, 1, 0), 35)) * Gf.Matrix4d().SetTranslate(Gf.Vec3d(0.05, -0.02, 0.01))
        xf.AddTransformOp().Set(m)
    elif op == "orient":
        xf.AddOrientOp().Set(Gf.Quatf(Gf.Rotation(Gf.Vec3d(0, 0, 1), 50).GetQuat()))
    elif op == "rotateZYX":
        xf.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.03, 0.0))
        xf.AddRotateZYXOp().Set(Gf.Vec3f(15, -25, 40))
    elif op == "pivot":
        xf.AddTranslateOp(opSuffix="pivot").Set(Gf.Vec3d(0.02, 0.0, -0.03))
        xf.AddRotateXOp().Set(30.0)
        xf.AddTranslateOp(opSuffix="pivot", isInverseOp=True)
    elif op == "scale":
        xf.AddScaleOp().Set(Gf.Vec3f(0.5, 0.5, 0.5))
    elif op == "rotateY":
        xf.AddRotateYOp().Set(-70.0)
    elif op == "translate":
        xf.AddTranslateOp().Set(Gf.Vec3d(-0.04, 0.0, 0.02))


def write(path, cases, mpu, up):
    # The encoding follows the extension: .usda text, .usdc binary crate; a .usdz is the
    # .usdc beside it packed by USD's own packager.
    layer = path[:-1] + "c" if path.endswith(".usdz") else path
    stage = Usd.Stage.CreateNew(layer)
    UsdGeom.SetStageMetersPerUnit(stage, mpu)
    UsdGeom.SetStageUpAxis(stage, up)
    root = UsdGeom.Xform.Define(stage, "/groom")
    root.AddTranslateOp().Set(Gf.Vec3d(0.1, 0.2, 0.3))
    root.AddRotateXYZOp().Set(Gf.Vec3f(10, 20, 30))
    root.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
    inner = UsdGeom.Xform.Define(stage, "/groom/inner")
    inner.AddRotateZOp().Set(12.0)
    expected = {"counts": [], "points": [], "widths": [], "colors": [], "opacities": []}
    ci = 0
    for k, (basis, wrap, counts, winterp, op) in enumerate(cases):
        c = UsdGeom.BasisCurves.Define(stage, f"/groom/inner/c{k}")
        c.CreateTypeAttr("linear" if basis == "linear" else "cubic")
        if basis != "linear":
            c.CreateBasisAttr(basis)
        c.CreateWrapAttr(wrap)
        add_op(c, op)
        pts, widths = [], []
        for n in counts:
            cp = curve_points(ci, n, basis)
            pts += cp
            segs = segments(basis, wrap, n)
            if winterp == "vertex":
                w = [0.0004 + 0.0001 * j for j in range(n)]
            else:
                ends = segs if wrap == "periodic" and basis != "linear" else segs + 1
                w = [0.0005 + 0.0002 * j for j in range(ends)]
            widths.append(w)
            ci += 1
        c.CreateCurveVertexCountsAttr(Vt.IntArray(counts))
        c.CreatePointsAttr(Vt.Vec3fArray(pts))
        c.CreateWidthsAttr(Vt.FloatArray([x for w in widths for x in w]))
        c.SetWidthsInterpolation(winterp)
        colors = [Gf.Vec3f(0.2 + 0.1 * k, 0.5, 1.0 - 0.05 * j) for j in range(len(counts))]
        pv = UsdGeom.PrimvarsAPI(c).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray)
        pv.Set(Vt.Vec3fArray(colors))
        pv.SetInterpolation("uniform")
        opacity = [0.3 + 0.05 * j for j in range(len(counts))]
        po = UsdGeom.PrimvarsAPI(c).CreatePrimvar("displayOpacity", Sdf.ValueTypeNames.FloatArray)
        po.Set(Vt.FloatArray(opacity))
        po.SetInterpolation("uniform")
        # What Kami must read: stage numbers are float32 in the file.
        xf = c.ComputeLocalToWorldTransform(Usd.TimeCode.Default())
        scale = abs(xf.GetDeterminant3()) ** (1 / 3) * mpu / 0.01
        at = 0
        for j, n in enumerate(counts):
            cp = [Gf.Vec3d(*(float(x) for x in p)) for p in pts[at : at + n]]
            at += n
            world = [Gf.Vec3d(*to_kami(p, xf, mpu, up)) for p in cp]
            # The basis is affine: transforming control points = transforming the curve.
            xs = sample(basis, wrap, world)
            expected["counts"].append(len(xs))
            expected["points"] += [tuple(p) for p in xs]
            wf = [float(Vt.FloatArray([x])[0]) for x in widths[j]]
            if winterp == "vertex":
                ws = sample(basis, wrap, wf)
            else:
                ws = sample(basis, wrap, [0.0] * n, varying=wf)
            expected["widths"] += [max(0.0, w * scale) for w in ws]
            col = colors[j]
            expected["colors"] += [tuple(srgb(float(x)) for x in col)] * len(xs)
            expected["opacities"] += [float(Vt.FloatArray([opacity[j]])[0])] * len(xs)
    stage.GetRootLayer().Save()
    if path.endswith(".usdz"):
        assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(layer), path)
    return expected


def animated(path):
    """Three linear curves of five points swaying in x: samples at time codes 1, 4, 7, 10
    and 12, printed as USD resolves them at every time code from start to end."""
    layer = path[:-1] + "c" if path.endswith(".usdz") else path
    stage = Usd.Stage.CreateNew(layer)
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    stage.SetTimeCodesPerSecond(30)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(12)
    c = UsdGeom.BasisCurves.Define(stage, "/cache")
    c.CreateTypeAttr("linear")
    c.CreateCurveVertexCountsAttr(Vt.IntArray([5, 5, 5]))
    c.CreateWidthsAttr(Vt.FloatArray([0.05])).Set(Vt.FloatArray([0.05]))
    c.SetWidthsInterpolation("constant")
    pts = c.CreatePointsAttr()
    for t in [1, 4, 7, 10, 12]:
        sway = math.sin(0.3 * t)
        frame = [Gf.Vec3f(k + sway * j * 0.2, 10.0 - 2.0 * j, 0.1 * t) for k in range(3) for j in range(5)]
        pts.Set(Vt.Vec3fArray(frame), Usd.TimeCode(t))
    stage.GetRootLayer().Save()
    if path.endswith(".usdz"):
        assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(layer), path)
    print("fps", stage.GetTimeCodesPerSecond())
    for t in range(1, 13):
        print("frame", t, *(repr(float(v)) for p in pts.Get(Usd.TimeCode(t)) for v in p))


def show(expected):
    print("counts", *expected["counts"])
    print("points", *(repr(v) for p in expected["points"] for v in p))
    print("widths", *(repr(v) for v in expected["widths"]))
    print("colors", *(repr(v) for p in expected["colors"] for v in p))
    print("opacities", *(repr(v) for v in expected["opacities"]))


def main():
    mode, path = sys.argv[1], sys.argv[2]
    if mode == "mixed":
        show(write(path, CASES, 1.0, UsdGeom.Tokens.z))
    elif mode == "animated":
        animated(path)
    elif mode == "crate":
        out = sys.argv[3]
        layer = out[:-1] + "c" if out.endswith(".usdz") else out
        assert Sdf.Layer.FindOrOpen(path).Export(layer)
        if out.endswith(".usdz"):
            assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(layer), out)
    elif mode == "single":
        show(write(path, [("catmullRom", "pinned", [4, 6, 2], "vertex", "rotateY")], 0.01, UsdGeom.Tokens.y))
    else:
        stage = Usd.Stage.Open(path)
        for p in stage.Traverse():
            if p.IsA(UsdGeom.BasisCurves):
                c = UsdGeom.BasisCurves(p)
                print("curve", c.GetTypeAttr().Get(), c.GetBasisAttr().Get(), c.GetWrapAttr().Get())
                print("counts", *c.GetCurveVertexCountsAttr().Get())
                print("points", *(repr(v) for q in c.GetPointsAttr().Get() for v in q))
                print("widths", *(repr(w) for w in c.GetWidthsAttr().Get()))
        print("metersPerUnit", UsdGeom.GetStageMetersPerUnit(stage), "upAxis", UsdGeom.GetStageUpAxis(stage))


main()
