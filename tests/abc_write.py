"""Write an Alembic groom with the real Alembic library (pip install alembic3d), for
tests/it/alembic.rs: `abc_write.py CASE OUT.abc [SAMPLE]`. After writing, it reads the file
back with Alembic and prints, per curves object, its path and its points in world space at
sample SAMPLE (the parents' IXform matrices as Alembic composes them), floats as repr.

Cases: linear (vertex widths, vertex colours, uniform opacity), cubic (bspline with varying
widths, catmullRom with a constant width, periodic bezier with indexed uniform colours),
xforms (curves under nested, non-inheriting and matrix transforms), animated (three samples
at 24 fps of moving curves under a moving transform), indexed (indexed uniform colours and an
indexed constant width), bytes (8-bit colours `Cd` beside an integer `Cs`), empty (an archive
without curves), unreal (Unreal Engine's groom schema as MetaHuman and Houdini export it: render
strands with `groom_width` over Maya's `width`, `groom_color`, `groom_group_id`, `groom_root_uv`,
and a guides object with a constant `groom_guide` of 1; `groom_version_major/minor`),
guides_only (every curve a guide: refused)."""
import sys

import imath
from alembic3d import Abc, AbcCoreAbstract, AbcGeom

G = AbcGeom
Scope = G.GeometryScope


def v3f(points):
    a = imath.V3fArray(len(points))
    for i, p in enumerate(points):
        a[i] = imath.V3f(*p)
    return a


def ints(values):
    a = imath.IntArray(len(values))
    for i, v in enumerate(values):
        a[i] = v
    return a


def floats(values):
    a = imath.FloatArray(len(values))
    for i, v in enumerate(values):
        a[i] = v
    return a


def colors(values):
    a = imath.C3fArray(len(values))
    for i, v in enumerate(values):
        a[i] = imath.Color3f(*v)
    return a


def curves(parent, name, points, counts, kind, wrap, basis, widths=None, ts=None):
    obj = G.OCurves(parent, name, ts) if ts is not None else G.OCurves(parent, name)
    schema = obj.getSchema()
    w = G.OFloatGeomParamSample(floats(widths[0]), widths[1]) if widths else G.OFloatGeomParamSample()
    schema.set(G.OCurvesSchemaSample(v3f(points), ints(counts), kind, wrap, w, G.OV2fGeomParamSample(),
                                     G.ON3fGeomParamSample(), basis))
    return obj, schema


def xform(parent, name, sample):
    x = G.OXform(parent, name)
    x.getSchema().set(sample)
    return x


def write(case, path):
    archive = Abc.OArchive(path)
    top = archive.getTop()
    lin, cub = G.CurveType.kLinear, G.CurveType.kCubic
    non, per = G.CurvePeriodicity.kNonPeriodic, G.CurvePeriodicity.kPeriodic
    if case == "linear":
        pts = [(0, 0, 0), (0, 1, 0), (0, 2, 0.5), (1, 0, 0), (1, 1.5, 0)]
        obj, schema = curves(top, "hair", pts, [3, 2], lin, non, G.BasisType.kNoBasis,
                             ([0.1, 0.2, 0.3, 0.4, 0.5], Scope.kVertexScope))
        arb = schema.getArbGeomParams()
        cs = G.OC3fGeomParam(arb, "Cs", False, Scope.kVertexScope, 1)
        cs.set(G.OC3fGeomParamSample(colors([(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (0, 1, 1)]),
                                     Scope.kVertexScope))
        op = G.OFloatGeomParam(arb, "opacity", False, Scope.kUniformScope, 1)
        op.set(G.OFloatGeomParamSample(floats([0.5, 0.25]), Scope.kUniformScope))
    elif case == "cubic":
        six = [(0, i, 0) for i in range(6)]
        curves(top, "bspline", six, [6], cub, non, G.BasisType.kBsplineBasis,
               ([0.1, 0.2, 0.3, 0.4], Scope.kVaryingScope))
        four = [(1, i, 0) for i in range(4)]
        curves(top, "catmull", four, [4], cub, non, G.BasisType.kCatmullromBasis,
               ([0.25], Scope.kConstantScope))
        six = [(2, i, i % 2) for i in range(6)]
        obj, schema = curves(top, "bezier", six + six, [6, 6], cub, per, G.BasisType.kBezierBasis,
                             ([0.5, 0.6], Scope.kUniformScope))
        arb = schema.getArbGeomParams()
        dc = G.OC3fGeomParam(arb, "displayColor", True, Scope.kUniformScope, 1)
        idx = imath.UnsignedIntArray(2)
        idx[0], idx[1] = 1, 0
        dc.set(G.OC3fGeomParamSample(colors([(0.2, 0.3, 0.4), (0.9, 0.8, 0.7)]), idx, Scope.kUniformScope))
    elif case == "xforms":
        a = G.XformSample()
        a.setTranslation(imath.V3d(1, 2, 3))
        a.setRotation(imath.V3d(0, 1, 0), 90)
        a.setScale(imath.V3d(2, 2, 2))
        outer = xform(top, "outer", a)
        b = G.XformSample()
        b.addOp(G.XformOp(G.XformOperationType.kRotateZOperation, 0), 30.0)
        b.addOp(G.XformOp(G.XformOperationType.kTranslateOperation, 0), imath.V3d(0, 0.5, 0))
        inner = xform(outer, "inner", b)
        pts = [(0, 0, 0), (0, 1, 0), (0.5, 2, 0)]
        curves(inner, "a", pts, [3], lin, non, G.BasisType.kNoBasis, ([0.1, 0.1, 0.1], Scope.kVertexScope))
        c = G.XformSample()
        c.setTranslation(imath.V3d(0, 10, 0))
        c.setInheritsXforms(False)
        alone = xform(outer, "alone", c)
        curves(alone, "b", pts, [3], lin, non, G.BasisType.kNoBasis, ([0.1], Scope.kConstantScope))
        d = G.XformSample()
        d.setMatrix(imath.M44d(0, 0, -1, 0, 0, 3, 0, 0, 1, 0, 0, 0, 4, 5, 6, 1))
        matrix = xform(top, "matrix", d)
        curves(matrix, "c", pts, [3], lin, non, G.BasisType.kNoBasis, ([0.2], Scope.kConstantScope))
    elif case == "animated":
        ts = archive.addTimeSampling(AbcCoreAbstract.TimeSampling(1.0 / 24.0, 0.0))
        x = G.OXform(top, "move", ts)
        obj, schema = curves(x, "hair", [(0, 0, 0), (0, 1, 0)], [2], lin, non, G.BasisType.kNoBasis,
                             ([0.1, 0.2], Scope.kVertexScope), ts)
        for frame in range(3):
            s = G.XformSample()
            s.setTranslation(imath.V3d(frame, 0, 0))
            x.getSchema().set(s)
            if frame > 0:
                w = G.OFloatGeomParamSample(floats([0.1 * (frame + 1), 0.2]), Scope.kVertexScope)
                schema.set(G.OCurvesSchemaSample(v3f([(0, 0, 0), (0, 1 + frame, 0)]), ints([2]), lin, non, w,
                                                 G.OV2fGeomParamSample(), G.ON3fGeomParamSample(),
                                                 G.BasisType.kNoBasis))
    elif case == "indexed":
        pts = [(i // 4, i % 4, 0) for i in range(8)]
        obj = G.OCurves(top, "hair")
        schema = obj.getSchema()
        zero = imath.UnsignedIntArray(1)
        zero[0] = 0
        w = G.OFloatGeomParamSample(floats([0.05]), zero, Scope.kConstantScope)
        schema.set(G.OCurvesSchemaSample(v3f(pts), ints([4, 4]), cub, non, w, G.OV2fGeomParamSample(),
                                         G.ON3fGeomParamSample(), G.BasisType.kBezierBasis))
        dc = G.OC3fGeomParam(schema.getArbGeomParams(), "displayColor", True, Scope.kUniformScope, 1)
        idx = imath.UnsignedIntArray(2)
        idx[0], idx[1] = 1, 0
        dc.set(G.OC3fGeomParamSample(colors([(0.2, 0.3, 0.4), (0.9, 0.8, 0.7)]), idx, Scope.kUniformScope))
    elif case == "bytes":
        obj, schema = curves(top, "hair", [(0, 0, 0), (0, 1, 0)], [2], lin, non, G.BasisType.kNoBasis)
        arb = schema.getArbGeomParams()
        cs = G.OV3iGeomParam(arb, "Cs", False, Scope.kVertexScope, 1)
        v = imath.V3iArray(2)
        v[0], v[1] = imath.V3i(1, 2, 3), imath.V3i(4, 5, 6)
        cs.set(G.OV3iGeomParamSample(v, Scope.kVertexScope))
        cd = G.OC3cGeomParam(arb, "Cd", False, Scope.kVertexScope, 1)
        c = imath.C3cArray(2)
        c[0], c[1] = imath.Color3c(255, 0, 0), imath.Color3c(0, 51, 255)
        cd.set(G.OC3cGeomParamSample(c, Scope.kVertexScope))
    elif case in ("unreal", "guides_only"):
        def shorts(values):
            a = imath.ShortArray(len(values))
            for i, v in enumerate(values):
                a[i] = v
            return a

        def version(arb):
            for name, v in (("groom_version_major", 1), ("groom_version_minor", 5)):
                p = G.OInt16GeomParam(arb, name, False, Scope.kConstantScope, 1)
                p.set(G.OInt16GeomParamSample(shorts([v]), Scope.kConstantScope))

        if case == "unreal":
            # Six render strands of 3 points in two groups (ids 3 and 7).
            pts = [(i, j, 0.1 * i) for i in range(6) for j in range(3)]
            obj, schema = curves(top, "strands", pts, [3] * 6, lin, non, G.BasisType.kNoBasis,
                                 ([9.0] * 18, Scope.kVertexScope))
            arb = schema.getArbGeomParams()
            version(arb)
            gw = G.OFloatGeomParam(arb, "groom_width", False, Scope.kVertexScope, 1)
            gw.set(G.OFloatGeomParamSample(floats([0.01 * (k + 1) for k in range(18)]), Scope.kVertexScope))
            gc = G.OC3fGeomParam(arb, "groom_color", False, Scope.kUniformScope, 1)
            gc.set(G.OC3fGeomParamSample(colors([(0.1 * i, 0.5, 0.2) for i in range(6)]), Scope.kUniformScope))
            gid = G.OInt32GeomParam(arb, "groom_group_id", False, Scope.kUniformScope, 1)
            gid.set(G.OInt32GeomParamSample(ints([3, 3, 7, 7, 7, 3]), Scope.kUniformScope))
            uv = G.OV2fGeomParam(arb, "groom_root_uv", False, Scope.kUniformScope, 1)
            a = imath.V2fArray(6)
            for i in range(6):
                a[i] = imath.V2f(i / 6.0, 0.25)
            uv.set(G.OV2fGeomParamSample(a, Scope.kUniformScope))
        # Guides: two curves (one per group), flagged by a constant groom_guide.
        gpts = [(0, j, 0) for j in range(3)] + [(3, j, 0.3) for j in range(3)]
        obj, schema = curves(top, "guides", gpts, [3, 3], lin, non, G.BasisType.kNoBasis,
                             ([0.02], Scope.kConstantScope))
        arb = schema.getArbGeomParams()
        version(arb)
        guide = G.OInt16GeomParam(arb, "groom_guide", False, Scope.kConstantScope, 1)
        guide.set(G.OInt16GeomParamSample(shorts([1]), Scope.kConstantScope))
        gid = G.OInt32GeomParam(arb, "groom_group_id", False, Scope.kUniformScope, 1)
        gid.set(G.OInt32GeomParamSample(ints([3, 7]), Scope.kUniformScope))
    elif case == "empty":
        xform(top, "nothing", G.XformSample())
    else:
        sys.exit(f"unknown case {case}")


def world(obj, index):
    """The world matrix of obj's parents at sample index, as Alembic composes it."""
    m = imath.M44d()
    chain = []
    p = obj.getParent()
    while p is not None and p.getFullName() != "/":
        chain.append(p)
        p = p.getParent()
    for p in reversed(chain):
        if G.IXform.matches(p.getMetaData()):
            x = G.IXform(p, Abc.WrapExistingFlag.kWrapExisting).getSchema()
            s = x.getValue(Abc.ISampleSelector(index))
            m = s.getMatrix() * m if s.getInheritsXforms() else s.getMatrix()
    return m


def dump(path, index):
    top = Abc.IArchive(path).getTop()

    def walk(obj):
        for i in range(obj.getNumChildren()):
            child = obj.getChild(i)
            if G.ICurves.matches(child.getMetaData()):
                c = G.ICurves(child, Abc.WrapExistingFlag.kWrapExisting).getSchema()
                sample = c.getValue(Abc.ISampleSelector(index))
                m = world(child, index)
                pts = [imath.V3d(p[0], p[1], p[2]) * m for p in sample.getPositions()]
                print("object", child.getFullName())
                print("points", *(repr(v) for p in pts for v in (p[0], p[1], p[2])))
            walk(child)

    walk(top)


if __name__ == "__main__":
    write(sys.argv[1], sys.argv[2])
    dump(sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 0)
