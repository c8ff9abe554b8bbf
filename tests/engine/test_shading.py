"""Shader programs (engine/shading.py): image lookups as Cycles' CPU kernel does them, the
node functions, packing several materials' programs, and UV maps through the scene."""

import math
import warnings

import numpy as np
import pytest

from engine import shading
from engine.scene import Material, SceneBuilder, World
from engine.shading import OP_BLEND, OP_MAPPING, OP_MATH, Program, Texture
from tests import scenes

RNG = np.random.default_rng(14)


def _table(texels, interpolation, extension):
    """A ProgramTable holding just one image (for image_channel)."""
    prog = Program()
    prog.out = prog.image(Texture("t", texels, interpolation, extension), prog.uv(""), False)
    return shading.pack([prog], None, lambda name: 0)


def lookup(texels, x, y, interpolation="Linear", extension="REPEAT"):
    pt = _table(texels, interpolation, extension)
    return np.array([shading.image_channel(x, y, ch, pt.texels, pt.textures[0])
                     for ch in range(4)])


def image(h=4, w=5):
    return RNG.random((h, w, 4)).astype(np.float32)


def test_closest_reads_the_texel_under_the_point_with_every_extension():
    tex = image()
    h, w = tex.shape[:2]
    for iy in range(h):
        for ix in range(w):
            x, y = (ix + 0.3) / w, (iy + 0.8) / h
            np.testing.assert_array_equal(lookup(tex, x, y, "Closest"), tex[iy, ix])
            # Repeat: one period over, the same texel; Mirror: reflected at 0.
            np.testing.assert_array_equal(lookup(tex, x + 2.0, y - 1.0, "Closest"), tex[iy, ix])
            np.testing.assert_array_equal(lookup(tex, -x, y, "Closest", "MIRROR"), tex[iy, ix])
    np.testing.assert_array_equal(lookup(tex, 1.7, -0.2, "Closest", "EXTEND"), tex[0, w - 1])
    np.testing.assert_array_equal(lookup(tex, 1.01, 0.5, "Closest", "CLIP"), np.zeros(4))
    np.testing.assert_array_equal(lookup(tex, 2.5 / w, 1.5 / h, "Closest", "CLIP"), tex[1, 2])


def test_linear_is_exact_at_texel_centres_and_blends_across_the_repeat_seam():
    tex = image()
    h, w = tex.shape[:2]
    np.testing.assert_allclose(lookup(tex, 2.5 / w, 1.5 / h), tex[1, 2], atol=1e-6)
    # Half way between texel columns 1 and 2, a quarter way from row 3 to row 0 (wrapped).
    got = lookup(tex, 2.0 / w, 3.75 / h)
    want = 0.75 * 0.5 * (tex[3, 1] + tex[3, 2]) + 0.25 * 0.5 * (tex[0, 1] + tex[0, 2])
    np.testing.assert_allclose(got, want, atol=1e-6)
    # At x = 0 Repeat mixes the first and last columns, Extend keeps the first.
    y = 1.5 / h
    np.testing.assert_allclose(lookup(tex, 0.0, y), 0.5 * (tex[1, 0] + tex[1, w - 1]), atol=1e-6)
    np.testing.assert_allclose(lookup(tex, 0.0, y, extension="EXTEND"), tex[1, 0], atol=1e-6)
    np.testing.assert_allclose(lookup(tex, 0.0, y, extension="CLIP"), 0.5 * tex[1, 0], atol=1e-6)


def test_cubic_is_cycles_b_spline():
    """The uniform cubic B-spline: weights 1/6, 2/3, 1/6 at a texel centre (a smoothing
    filter, not interpolating), and a constant image stays constant."""
    tex = image(6, 6)
    x, y = 2.5 / 6, 3.5 / 6
    k = np.array([1 / 6, 2 / 3, 1 / 6])
    want = np.einsum("i,j,ijc->c", k, k, tex[2:5, 1:4].astype(np.float64))
    np.testing.assert_allclose(lookup(tex, x, y, "Cubic"), want, atol=1e-6)
    flat = np.full((3, 4, 4), 0.3, np.float32)
    for extension in ("REPEAT", "EXTEND", "MIRROR"):
        np.testing.assert_allclose(lookup(flat, 0.07, 0.93, "Cubic", extension), 0.3, atol=1e-6)


def test_srgb_images_are_decoded_after_interpolation():
    """Cycles keeps byte sRGB images encoded and decodes the interpolated value."""
    tex = np.zeros((1, 2, 4), np.float32)
    tex[0, 1] = 1.0
    prog = Program()
    prog.out = prog.image(Texture("s", tex, "Linear", "EXTEND", srgb=True), prog.uv(""), False)
    got = shading.evaluate(prog, (0.5, 0.5))[prog.out]
    assert got == pytest.approx(((0.5 + 0.055) / 1.055) ** 2.4, abs=1e-7)


def test_mapping_blend_and_math():
    prog = Program()
    uv = prog.uv("")
    # Mapping (Point): scale 2 then translate by (0.25, 0, 0).
    mapped = prog.emit(OP_MAPPING, 3, a=uv, params=[2, 0, 0, 0.25, 0, 2, 0, 0, 0, 0, 2, 0])
    a, b = prog.const([0.2, 0.5, 0.8]), prog.const([0.6, 0.1, 1.0])
    fac = prog.const([0.25])
    mul = prog.emit(OP_BLEND, 3, a=fac, b=a, c=b, d=shading.BLENDS.index("MULTIPLY"))
    screen = prog.emit(OP_BLEND, 3, a=fac, b=a, c=b, d=shading.BLENDS.index("SCREEN"), e=1)
    power = prog.emit(OP_MATH, 1, a=mapped, b=fac, c=fac, d=shading.MATHS.index("POWER"))
    reg = shading.evaluate(prog, (0.3, 0.7))
    np.testing.assert_allclose(reg[mapped:mapped + 3], [0.85, 1.4, 0.0])
    av, bv = np.array([0.2, 0.5, 0.8]), np.array([0.6, 0.1, 1.0])
    np.testing.assert_allclose(reg[mul:mul + 3], av * (0.75 + 0.25 * bv))
    np.testing.assert_allclose(reg[screen:screen + 3], 1 - (0.75 + 0.25 * (1 - bv)) * (1 - av))
    assert reg[power] == pytest.approx(0.85 ** 0.25)


def test_colour_conversions_invert_each_other(rng):
    """Separate / Combine Color's HSV and HSL conversions (Cycles' util/color.h) undo each
    other, and give the textbook values on the primaries."""
    for rgb in rng.uniform(0.0, 1.0, (200, 3)):
        for there, back in (("RGB_TO_HSV", "HSV_TO_RGB"), ("RGB_TO_HSL", "HSL_TO_RGB")):
            mid = shading.convert_colour(shading.CONVERSIONS.index(there), *rgb)
            np.testing.assert_allclose(
                shading.convert_colour(shading.CONVERSIONS.index(back), *mid), rgb, atol=1e-12)
    hsl = shading.CONVERSIONS.index("RGB_TO_HSL")
    assert shading.convert_colour(hsl, 0.0, 0.0, 1.0) == pytest.approx((2 / 3, 1.0, 0.5))
    assert shading.convert_colour(hsl, 1.0, 0.5, 0.5) == pytest.approx((0.0, 1.0, 0.75))


def test_blend_modes_of_hsv_keep_what_they_do_not_take():
    """Hue takes b's hue (a's saturation and value stay), Color b's hue and saturation,
    Saturation and Value blend one of a's channels toward b's; a grey b has no hue to
    give."""
    hsv = shading.CONVERSIONS.index("RGB_TO_HSV")
    a, b = (0.8, 0.4, 0.2), (0.1, 0.3, 0.9)
    ha, sa, va = shading.convert_colour(hsv, *a)
    hb, sb, vb = shading.convert_colour(hsv, *b)
    for mode, want in (("HUE", (hb, sa, va)), ("COLOR", (hb, sb, va)),
                       ("SATURATION", (ha, sb, va)), ("VALUE", (ha, sa, vb))):
        got = shading.blend_colour(shading.BLENDS.index(mode), 1.0, *a, *b)
        assert shading.convert_colour(hsv, *got) == pytest.approx(want), mode
    grey = (0.5, 0.5, 0.5)
    assert shading.blend_colour(shading.BLENDS.index("HUE"), 1.0, *a, *grey) == \
        pytest.approx(a)


@pytest.mark.parametrize("op, a, b, want", [
    ("DIVIDE", 1.0, 0.0, 0.0), ("POWER", -2.0, 0.5, 0.0), ("POWER", -2.0, 3.0, -8.0),
    ("POWER", 0.0, -1.0, 0.0), ("SQRT", -4.0, 0.0, 0.0), ("MODULO", 5.5, 2.0, 1.5),
    ("MODULO", 1.0, 0.0, 0.0), ("FRACT", -0.25, 0.0, 0.75), ("WRAP", 1.25, 1.0, 0.25),
    ("PINGPONG", 1.25, 1.0, 0.75), ("PINGPONG", 0.5, 0.0, 0.0), ("LOGARITHM", 8.0, 2.0, 3.0),
    ("LOGARITHM", -1.0, 2.0, 0.0), ("EXPONENT", 1000.0, 0.0, math.exp(700.0))])
def test_math_is_safe_where_cycles_is(op, a, b, want):
    """No NaN or inf from a node: Cycles' safe division, power, root and modulo."""
    got = shading.math_op(shading.MATHS.index(op), a, b, 0.0)
    assert math.isfinite(got) and got == pytest.approx(want)


def test_math_angles_trigonometry_and_smooth_extrema_are_cycles(rng):
    """The Math node's angle, trigonometric, hyperbolic and smooth min/max operations
    against their formulas (Cycles' svm_math: arcsine and arccosine of the clamped value,
    atan2 of the origin 0, smoothminf's cubic blend over the distance c), at random values
    and where Cycles is safe; every operation Blender's Math node offers is one of them."""
    for a, b, c in rng.normal(size=(20, 3)) * 2.0:
        h = max(abs(c) - abs(a - b), 0.0) / abs(c)
        want = {"INVERSE_SQRT": 1 / np.sqrt(a) if a > 0 else 0.0, "RADIANS": np.radians(a),
                "DEGREES": np.degrees(a), "TANGENT": np.tan(a), "SINH": np.sinh(a),
                "COSH": np.cosh(a), "TANH": np.tanh(a), "ARCSINE": np.arcsin(np.clip(a, -1, 1)),
                "ARCCOSINE": np.arccos(np.clip(a, -1, 1)), "ARCTANGENT": np.arctan(a),
                "ARCTAN2": np.arctan2(a, b),
                "SMOOTH_MIN": min(a, b) - h ** 3 * abs(c) / 6,
                "SMOOTH_MAX": max(a, b) + h ** 3 * abs(c) / 6}
        for op, w in want.items():
            got = shading.math_op(shading.MATHS.index(op), a, b, abs(c))
            assert got == pytest.approx(w, rel=1e-12, abs=1e-12), (op, a, b, c)
    assert shading.math_op(shading.MATHS.index("ARCTAN2"), 0.0, 0.0, 0.0) == 0.0
    assert shading.math_op(shading.MATHS.index("SMOOTH_MIN"), 0.3, 0.7, 0.0) == 0.3
    assert shading.math_op(shading.MATHS.index("SMOOTH_MAX"), 0.3, 0.7, 0.0) == 0.7
    assert math.isfinite(shading.math_op(shading.MATHS.index("COSH"), 1e4, 0.0, 0.0))
    blender = {"ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "POWER", "LOGARITHM",
               "SQRT", "INVERSE_SQRT", "ABSOLUTE", "EXPONENT", "MINIMUM", "MAXIMUM",
               "LESS_THAN", "GREATER_THAN", "SIGN", "COMPARE", "SMOOTH_MIN", "SMOOTH_MAX",
               "ROUND", "FLOOR", "CEIL", "TRUNC", "FRACT", "MODULO", "FLOORED_MODULO", "WRAP",
               "SNAP", "PINGPONG", "SINE", "COSINE", "TANGENT", "ARCSINE", "ARCCOSINE",
               "ARCTANGENT", "ARCTAN2", "SINH", "COSH", "TANH", "RADIANS", "DEGREES"}
    assert set(shading.MATHS) == blender


def _vector_math(op, a, b, c=(0.0, 0.0, 0.0), scale=1.0):
    prog = Program()
    ra, rb, rc, rs = prog.const(a), prog.const(b), prog.const(c), prog.const([scale])
    out = prog.emit(shading.OP_VECTOR_MATH, 4, a=ra, b=rb, c=rc,
                    d=shading.VECTOR_MATHS.index(op), e=rs)
    reg = shading.evaluate(prog)
    return reg[out:out + 3], reg[out + 3]


def test_vector_math_is_cycles_per_operation(rng):
    """Every Vector Math operation against its formula (Cycles' svm_vector_math, with its
    safe division, projection and normalisation), on random vectors and at the zeros where
    Cycles is safe."""
    a, b, c = rng.normal(size=(3, 3))
    s = 1.3
    n = b / np.linalg.norm(b)
    d = a @ n
    k = 1 - s * s * (1 - d * d)
    want = {
        "ADD": a + b, "SUBTRACT": a - b, "MULTIPLY": a * b, "DIVIDE": a / b,
        "MULTIPLY_ADD": a * b + c, "CROSS_PRODUCT": np.cross(a, b),
        "PROJECT": b * (a @ b) / (b @ b), "REFLECT": a - 2 * d * n,
        "REFRACT": s * a - (s * d + np.sqrt(max(k, 0))) * n if k >= 0 else np.zeros(3),
        "FACEFORWARD": a if c @ b < 0 else -a, "DOT_PRODUCT": a @ b,
        "DISTANCE": np.linalg.norm(a - b), "LENGTH": np.linalg.norm(a), "SCALE": a * s,
        "NORMALIZE": a / np.linalg.norm(a), "SNAP": np.floor(a / b) * b,
        "FLOOR": np.floor(a), "CEIL": np.ceil(a), "MODULO": np.fmod(a, b),
        "WRAP": a - (b - c) * np.floor((a - c) / (b - c)), "FRACTION": a - np.floor(a),
        "ABSOLUTE": np.abs(a), "POWER": np.where((a < 0) & (b != np.floor(b)), 0.0,
                                                  np.abs(a) ** b * np.where(a < 0, np.nan, 1)),
        "SIGN": np.sign(a), "MINIMUM": np.minimum(a, b), "MAXIMUM": np.maximum(a, b),
        "SINE": np.sin(a), "COSINE": np.cos(a), "TANGENT": np.tan(a)}
    assert set(want) == set(shading.VECTOR_MATHS)
    for op, w in want.items():
        vec, value = _vector_math(op, a, b, c, s)
        got = value if np.ndim(w) == 0 else vec
        if op == "POWER":  # a negative base with a fractional exponent gives 0
            w = np.nan_to_num(w, nan=0.0)
        np.testing.assert_allclose(got, w, rtol=1e-12, atol=1e-12, err_msg=op)
        if np.ndim(w) == 0:
            assert not vec.any(), op
        else:
            assert value == 0.0, op
    zero = np.zeros(3)
    for op in ("DIVIDE", "PROJECT", "SNAP", "MODULO"):  # by 0: 0, as Cycles' safe ones
        vec, _ = _vector_math(op, a, zero)
        assert not vec.any(), op
    vec, _ = _vector_math("NORMALIZE", zero, zero)
    assert not vec.any()


def _fresnel_exact(cos, eta):
    """The unpolarised dielectric Fresnel, written out (Cycles' fresnel_dielectric_cos)."""
    c = abs(cos)
    g2 = eta * eta - 1 + c * c
    if g2 <= 0:
        return 1.0
    g = math.sqrt(g2)
    a, b = (g - c) / (g + c), (c * (g + c) - 1) / (c * (g - c) + 1)
    return 0.5 * a * a * (1 + b * b)


def _random_views(rng, n):
    """n random (unit normal, unit direction toward the viewer) pairs."""
    for _ in range(n):
        pair = rng.normal(size=(2, 3))
        yield pair / np.linalg.norm(pair, axis=1, keepdims=True)


@pytest.mark.parametrize("backfacing", [False, True])
def test_fresnel_and_layer_weight_read_the_view_at_the_hit(rng, backfacing):
    """Cycles' Fresnel and Layer Weight nodes at random views of a hit: the IOR inverted
    on a back face (Fresnel), not inverted there (Layer Weight's Fresnel, whose eta is
    1 / (1 - blend) from the front), Facing as 1 - |cos|^(blend curve); an explicit
    Normal input replaces the hit's."""
    prog = Program()
    ior, blend = prog.const([1.45]), prog.const([0.3])
    tilted = prog.const([0.0, 0.6, 0.8])
    fresnel = prog.emit(shading.OP_FRESNEL, 1, a=ior, b=-1)
    fresnel_tilted = prog.emit(shading.OP_FRESNEL, 1, a=ior, b=tilted)
    layer = prog.emit(shading.OP_LAYER_WEIGHT, 2, a=blend, b=-1)
    for n, i in _random_views(rng, 20):
        reg = shading.evaluate(prog, normal=n, incoming=i, backfacing=backfacing)
        cos = n @ i
        eta = 1 / 1.45 if backfacing else 1.45
        assert reg[fresnel] == pytest.approx(_fresnel_exact(cos, eta), abs=1e-12)
        assert reg[fresnel_tilted] == pytest.approx(
            _fresnel_exact(np.array([0.0, 0.6, 0.8]) @ i, eta), abs=1e-12)
        eta_lw = 0.7 if backfacing else 1 / 0.7
        assert reg[layer] == pytest.approx(_fresnel_exact(cos, eta_lw), abs=1e-12)
        assert reg[layer + 1] == pytest.approx(1 - abs(cos) ** 0.6, abs=1e-12)


def test_programs_of_several_materials_keep_their_own_images_and_parameters():
    progs = []
    for k in range(3):
        p = Program()
        tex = np.full((2, 2, 4), 0.1 * (k + 1), np.float32)
        scaled = p.emit(OP_MAPPING, 3, a=p.uv(f"map{k}"),
                        params=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0])
        p.out = p.image(Texture(f"t{k}", tex, "Closest"), scaled, False)
        progs.append(p)
    names = ["map0", "map1", "map2"]
    pt = shading.pack([progs[0], None, progs[1], progs[2]], None, names.index)
    assert pt.colour[1, 0] == -1
    uv = np.zeros((3, 1, 3, 3), np.float32)
    reg = np.zeros(shading.MAX_REGISTERS)
    for mat, k in ((0, 0), (2, 1), (3, 2)):
        c = shading.colour_at(mat, 0, 0.2, 0.2, pt, uv, reg, -1.0, -1.0, -1.0)
        np.testing.assert_allclose(c, 0.1 * (k + 1), rtol=1e-6)
    assert shading.colour_at(1, 0, 0.2, 0.2, pt, uv, reg, 0.5, 0.6, 0.7) == (0.5, 0.6, 0.7)


def test_an_image_read_by_several_programs_is_stored_once():
    """Two programs reading one Texture, and a Texture of the same texels under another
    filter, keep one copy of the texels in the table; each lookup keeps its own filter."""
    texels = np.random.default_rng(3).random((4, 4, 4)).astype(np.float32)
    linear, closest = Texture("t", texels, "Linear"), Texture("t", texels, "Closest")
    assert linear.texels is closest.texels is texels
    progs = []
    for tex in (linear, linear, closest):
        p = Program()
        p.out = p.image(tex, p.uv(""), False)
        progs.append(p)
    pt = shading.pack(progs, None, lambda name: 0)
    assert len(pt.texels) == 16 and len(pt.textures) == 2
    uv = np.zeros((1, 1, 3, 3), np.float32)
    uv[0, 0, :, :2] = ((0.1, 0.1), (0.9, 0.1), (0.1, 0.9))
    reg = np.zeros(shading.MAX_REGISTERS)
    c = [shading.colour_at(m, 0, 0.3, 0.2, pt, uv, reg, -1.0, -1.0, -1.0) for m in range(3)]
    alone = shading.pack([progs[2]], None, lambda name: 0)
    assert c[0] == c[1] and c[2] == shading.colour_at(0, 0, 0.3, 0.2, alone, uv, reg,
                                                       -1.0, -1.0, -1.0) and c[0] != c[2]


def test_textures_validate_their_input():
    with pytest.raises(ValueError, match="'bad'.*interpolation"):
        Texture("bad", np.zeros((2, 2, 4)), "Bilinear")
    with pytest.raises(ValueError, match="'flat'.*\\(h, w, 4\\)"):
        Texture("flat", np.zeros((2, 4)))
    nan = Texture("nan", np.full((1, 1, 4), np.nan))
    assert np.all(nan.texels == 0)
    b = SceneBuilder()
    b.add_material(Material("clear", "transparent", colour_program=Program()))
    with pytest.raises(ValueError, match="'clear'.*cannot vary"):
        b.build(scenes.cornell_camera())


def test_uv_maps_follow_their_triangles_and_a_missing_map_is_named():
    b = SceneBuilder()
    prog = scenes.image_program(scenes.checker_texels())
    m = b.add_material(Material.diffuse("tex", (0.5, 0.5, 0.5), colour_program=prog))
    v, t = scenes.quad((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0))
    # A degenerate triangle first: it is dropped, and the UVs must drop with it.
    v = np.vstack([v, [(2, 0, 0)]])
    t = np.vstack([[[4, 4, 4]], t])
    uvs = np.vstack([np.full((1, 3, 2), 9.0), scenes.quad_uvs()])
    b.add_mesh("textured", v, t, m, uv_maps={"": uvs})
    b.add_mesh("plain", *scenes.quad((0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)), m)
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        scene = b.build(scenes.cornell_camera(), World())
    assert scene.uv.shape == (1, 4, 3, 3)
    np.testing.assert_array_equal(scene.uv[0, :2, :, :2], scenes.quad_uvs())
    np.testing.assert_array_equal(scene.uv[0, 2:], 0.0)
    assert any("'plain'" in w and "UV map" in w and "'tex'" in w for w in scene.warnings)


def test_normal_map_reads_the_colour_on_the_tangent_frame(rng):
    """Cycles' tangent-space Normal Map: (0.5, 0.5, 1) keeps the normal; a colour c gives
    (2c - 1) on (t, sign n x t, n), unnormalised frames included; a degenerate result
    keeps n."""
    for _ in range(20):
        n = rng.normal(size=3)
        t = np.cross(n, rng.normal(size=3))
        n *= rng.uniform(0.5, 2.0)
        sign = rng.choice([-1.0, 1.0])
        assert shading.normal_map(0.5, 0.5, 1.0, *t, sign, *n) == pytest.approx(
            n / np.linalg.norm(n))
        c = rng.uniform(0, 1, 3)
        expect = (2 * c[0] - 1) * t + (2 * c[1] - 1) * sign * np.cross(n, t) + \
            (2 * c[2] - 1) * n
        assert shading.normal_map(*c, *t, sign, *n) == pytest.approx(
            expect / np.linalg.norm(expect))
    assert shading.normal_map(0.5, 0.5, 0.5, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0) == \
        pytest.approx((0.0, 0.0, 1.0))


def test_normal_mapped_floor_leans_toward_its_map():
    """A floor whose normal map leans every normal toward +x (under the centred ceiling
    light): its left half faces the light and is brighter than its right half, where the
    plain floor (strength 0) is symmetric."""
    from engine import render
    lean = np.broadcast_to(np.float32((0.8, 0.5, 0.9, 1.0)), (2, 2, 4)).copy()
    st = scenes.settings(samples=32, max_bounces=0)
    halves = []
    for strength in (0.0, 1.0):
        r = render(scenes.normal_mapped_box(strength=strength, texels=lean), st)
        floor = r.combined[1:8, :, 0]  # the bottom rows: floor only
        halves.append((floor[:, 10:40].mean(), floor[:, 56:86].mean()))
    (flat_l, flat_r), (lean_l, lean_r) = halves
    assert abs(flat_l / flat_r - 1.0) < 0.05, halves
    assert lean_l / lean_r > 1.3, halves


def _plane_gradient_case(rng):
    """A unit normal n, two vectors e, f spanning its plane and a gradient g in it."""
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    e, f, g = (np.cross(n, rng.normal(size=3)) for _ in range(3))
    return n, e, f, g


def test_bump_tilts_the_normal_by_the_height_gradient_whatever_the_surface_vectors(rng):
    """Cycles' Bump node in the limit: the normal n - grad h (Distance included), normalised,
    from the height's derivatives along any two vectors spanning the surface, on either
    side; strength s blends toward n; a degenerate frame keeps n."""
    for _ in range(20):
        n, e, f, g = _plane_gradient_case(rng)
        expect = (n - g) / np.linalg.norm(n - g)
        for a, b in ((e, f), (f, e)):
            assert shading.bump_normal(*n, *a, *b, g @ a, g @ b, 1.0) == pytest.approx(expect)
        flipped = shading.bump_normal(*-n, *e, *f, g @ e, g @ f, 1.0)
        assert flipped == pytest.approx((-n - g) / np.linalg.norm(n + g))
        s = rng.uniform(0.1, 0.9)
        half = s * expect + (1 - s) * n
        assert shading.bump_normal(*n, *e, *f, g @ e, g @ f, s) == pytest.approx(
            half / np.linalg.norm(half))
        assert shading.bump_normal(*n, *e, *f, g @ e, g @ f, 0.0) == pytest.approx(n)
        assert shading.bump_normal(*n, *e, *e, g @ e, g @ e, 1.0) == pytest.approx(n)


def _slope_program(slope, strength=1.0):
    """A Bump node's program: Distance x Height = slope x u on the default UV map."""
    p = Program()
    u = p.uv("")
    k = p.const([slope])
    dh = p.emit(OP_MATH, 1, a=u, b=k, c=k, d=shading.MATHS.index("MULTIPLY"))
    s = p.const([strength])
    p.out = p.emit(shading.OP_COMBINE, 3, a=dh, b=s, c=s)
    return p


def test_a_sloped_bump_shades_as_the_normal_map_of_its_slope():
    """A floor bumped by the height 1.2 u (u = (x + 1) / 2: the gradient (0.6, 0, 0)) has
    the normal (-0.6, 0, 1) normalised everywhere; the floor whose normal map holds that
    normal renders the same, sample for sample. The unbumped floor does not."""
    from engine import render
    n = np.array([-0.6, 0.0, 1.0]) / np.hypot(0.6, 1.0)
    colour = np.float32(np.append((n + 1) / 2, 1.0))
    st = scenes.settings(samples=8, max_bounces=1)
    mapped = render(scenes.normal_mapped_box(texels=np.broadcast_to(colour, (2, 2, 4)).copy()),
                    st).combined
    bumped = render(scenes.normal_mapped_box(height=_slope_program(1.2)), st).combined
    flat = render(scenes.normal_mapped_box(strength=0.0), st).combined
    assert np.all(np.isfinite(bumped))
    # The map's colour is float32: its normal is 1e-7 off, which turns a few paths.
    assert np.isclose(bumped, mapped, rtol=1e-5, atol=1e-6).mean() > 0.999
    assert bumped.mean() == pytest.approx(mapped.mean(), rel=1e-4)
    floor = np.s_[1:8, :, :]
    assert abs(bumped[floor].mean() / flat[floor].mean() - 1.0) > 0.05


def _rotation(x, y, z):
    """Rz Ry Rx: Euler XYZ composed from the three axis rotations."""
    cx, cy, cz, sx, sy, sz = (math.cos(x), math.cos(y), math.cos(z), math.sin(x),
                              math.sin(y), math.sin(z))
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def test_mapping_of_each_type_with_its_inputs_in_registers(rng):
    """The Mapping node with every input a register: Point scales, turns (Euler XYZ, the
    axis rotations composed) and moves; Texture undoes Point (0 on an axis of zero scale);
    Vector ignores the location; Normal divides by the scale, turns and normalises."""
    for _ in range(10):
        vec, loc, rot = rng.normal(size=3), rng.normal(size=3), rng.uniform(-3, 3, 3)
        scale = rng.uniform(0.3, 2.0, 3) * rng.choice([-1, 1], 3)
        m = _rotation(*rot)
        got = {}
        for kind in shading.MAPPINGS:
            prog = Program()
            regs = [prog.const(list(x)) for x in (vec, loc, rot, scale)]
            out = prog.emit(shading.OP_VECTOR_MAPPING, 3, *regs, e=shading.MAPPINGS.index(kind))
            got[kind] = shading.evaluate(prog)[out:out + 3]
        np.testing.assert_allclose(got["POINT"], m @ (vec * scale) + loc, atol=1e-12)
        np.testing.assert_allclose(got["TEXTURE"], m.T @ (vec - loc) / scale, atol=1e-12)
        np.testing.assert_allclose(got["VECTOR"], m @ (vec * scale), atol=1e-12)
        n = m @ (vec / scale)
        np.testing.assert_allclose(got["NORMAL"], n / np.linalg.norm(n), atol=1e-12)
        # Texture's inverse of Point: mapping Point's result back gives the vector.
        prog = Program()
        regs = [prog.const(list(x)) for x in (got["POINT"], loc, rot, scale)]
        back = prog.emit(shading.OP_VECTOR_MAPPING, 3, *regs, e=1)
        np.testing.assert_allclose(shading.evaluate(prog)[back:back + 3], vec, atol=1e-12)
    prog = Program()
    regs = [prog.const(x) for x in ([1.0, 2.0, 3.0], [0.0] * 3, [0.0] * 3, [2.0, 0.0, 1.0])]
    out = prog.emit(shading.OP_VECTOR_MAPPING, 3, *regs, e=1)
    np.testing.assert_allclose(shading.evaluate(prog)[out:out + 3], [0.5, 0.0, 3.0])


def _transform(v, axes, origin, into, normal):
    """OP_TRANSFORM of v through the frame whose columns are `axes`' columns."""
    prog = Program()
    first = prog.const(list(axes[:, 0]))
    prog.const(list(axes[:, 1]))
    prog.const(list(axes[:, 2]))
    o = prog.const(list(origin)) if origin is not None else -1
    out = prog.emit(shading.OP_TRANSFORM, 3, a=prog.const(list(v)), b=first, c=o,
                    d=int(into), e=int(normal))
    return shading.evaluate(prog)[out:out + 3]


def test_transform_moves_points_vectors_and_normals_through_a_frame(rng):
    """OP_TRANSFORM, the Vector Transform node's step: out of a frame M, a point is M v + t
    and a vector M v; into it by components, (v - t) . M_j; a normal is normalised. Into
    the inverse's columns is the transposed inverse, a normal's transform, so a normal
    taken out of an object as Cycles does (M^-T n) stays perpendicular to a surface's
    vectors taken out as directions; a zero normal stays zero."""
    for _ in range(10):
        m, t, v = rng.normal(size=(3, 3)), rng.normal(size=3), rng.normal(size=3)
        np.testing.assert_allclose(_transform(v, m, t, False, False), m @ v + t, atol=1e-12)
        np.testing.assert_allclose(_transform(v, m, None, False, False), m @ v, atol=1e-12)
        np.testing.assert_allclose(_transform(v, m, t, True, False), m.T @ (v - t),
                                   atol=1e-12)
        n = m.T @ v
        np.testing.assert_allclose(_transform(v, m, None, True, True), n / np.linalg.norm(n),
                                   atol=1e-12)
        # A surface with tangent a and normal cross(a, b) in object space, out to world.
        a, b = rng.normal(size=3), rng.normal(size=3)
        normal = _transform(np.cross(a, b), np.linalg.inv(m), None, True, True)
        for tangent in (a, b):
            world = _transform(tangent, m, None, False, False)
            assert abs(normal @ world) < 1e-9 * np.linalg.norm(world)
    assert np.all(_transform(np.zeros(3), np.eye(3), None, True, True) == 0.0)


def test_box_projection_weights_are_a_continuous_partition(rng):
    """Cycles' box weights: one face near an axis (also at blend 0, everywhere), never
    negative, summing to 1, and with a blend continuous as the normal turns (its seven
    zones meet without jumps)."""
    for blend in (0.0, 0.2, 0.5, 1.0):
        for _ in range(10):  # along great circles, in steps of 3e-4 radians
            a, b = np.linalg.qr(rng.normal(size=(3, 2)))[0].T
            turn = np.linspace(0.0, 2.0 * np.pi, 20001)
            w = np.array([shading.box_weights(*(math.cos(t) * a + math.sin(t) * b), blend)
                          for t in turn])
            assert np.all(w >= -1e-12) and np.allclose(w.sum(axis=1), 1.0, atol=1e-12)
            if blend == 0.0:
                assert np.all(np.sort(w, axis=1) == [0.0, 0.0, 1.0])
            else:
                assert np.abs(np.diff(w, axis=0)).max() < 0.02, blend
        if blend <= 0.5:  # near enough the y axis for one face
            assert shading.box_weights(0.1, -0.9, 0.2, blend) == (0.0, 1.0, 0.0)


def test_sphere_and_tube_projections_of_the_unit_box(rng):
    """Sphere: v from the angle to +z, u turning once about z; Tube: v from z, u the same
    turn, on coordinates remapped from the 0..1 box about its centre."""
    for _ in range(50):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        co = 0.5 + 0.5 * rng.uniform(0.1, 1.0) * d  # a point in the box, direction d
        u, v = shading.sphere_tube(0, *co)
        assert v == pytest.approx(1.0 - math.acos(d[2]) / math.pi, abs=1e-9)
        turn = math.atan2(d[0], d[1])
        assert u == pytest.approx(0.5 - turn / (2 * math.pi), abs=1e-9)
        u, v = shading.sphere_tube(1, *co)
        assert v == pytest.approx(co[2], abs=1e-12)
        assert u == pytest.approx(0.5 - turn / (2 * math.pi), abs=1e-9)
    assert shading.sphere_tube(0, 0.5, 0.5, 0.5) == (0.0, 0.0)
    assert shading.sphere_tube(1, 0.5, 0.5, 0.9) == (0.0, 0.0)


def test_wireframe_marks_points_within_half_its_size_of_an_edge(rng):
    """The Wireframe node's Fac: 1 within size / 2 of any edge of the hit's triangle (its
    corners read from a map), 0 inside, whatever the triangle's size and turn."""
    for _ in range(20):
        turn = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        scale, size = rng.uniform(0.5, 3.0), rng.uniform(0.01, 0.2)
        corners = (np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]) * scale
                   @ turn.T + rng.normal(size=3))
        prog = Program()
        out = prog.emit(shading.OP_WIREFRAME, 1, a=prog.map_index(shading.POSITION),
                        b=prog.const([size]))
        pt = shading.pack([prog], None, lambda name: 0)
        uv = corners.astype(np.float32)[None, None]
        for u, v in rng.uniform(0.0, 1.0, (50, 2)) / 1.05:
            if u + v > 1.0:
                u, v = 1.0 - u, 1.0 - v
            reg = np.zeros(shading.MAX_REGISTERS)
            shading.run(0, len(pt.code), pt, uv, 0, u, v, reg)
            distance = scale * min(u, v, (1.0 - u - v) / math.sqrt(2.0))
            if abs(distance - size / 2) > 1e-4:
                assert reg[out] == float(distance < size / 2), (u, v, distance, size)


@pytest.mark.parametrize("backfacing", [False, True])
def test_reflection_normal_and_window_outputs(rng, backfacing):
    """Texture Coordinate's Reflection is the view mirrored about the shading normal (the
    direction a mirror sends the eye ray on); Normal is its map normalised and negated on a
    back face; Window divides its homogeneous map through (0 where w is 0)."""
    prog = Program()
    reflection = prog.emit(shading.OP_REFLECTION, 3)
    normal = prog.emit(shading.OP_FACING, 3, a=prog.const([0.0, 3.0, 4.0]))
    window = prog.emit(shading.OP_PROJECT, 3, a=prog.const([1.0, 3.0, 2.0]))
    flat = prog.emit(shading.OP_PROJECT, 3, a=prog.const([1.0, 3.0, 0.0]))
    for n, wi in _random_views(rng, 10):
        reg = shading.evaluate(prog, normal=n, incoming=wi, backfacing=backfacing)
        ray = -wi  # the eye ray, and where a mirror sends it
        np.testing.assert_allclose(reg[reflection:reflection + 3], ray - 2 * (ray @ n) * n,
                                   atol=1e-12)
        sign = -1 if backfacing else 1
        np.testing.assert_allclose(reg[normal:normal + 3], [0, sign * 0.6, sign * 0.8])
        np.testing.assert_allclose(reg[window:window + 3], [0.5, 1.5, 0.0])
        np.testing.assert_allclose(reg[flat:flat + 3], 0.0)


def _map_range(kind, value, ends, steps=4.0, clamp=False, width=1):
    prog = Program()
    regs = [prog.const([v] * width) for v in (value,) + tuple(ends) + (steps,)]
    out = prog.emit(shading.OP_MAP_RANGE, width, *regs[:5], params=[
        regs[5], shading.MAP_RANGES.index(kind), int(clamp), width])
    return shading.evaluate(prog)[out:out + width]


@pytest.mark.parametrize("width", [1, 3])
def test_map_range_of_each_type(rng, width):
    """Map Range: Linear maps the source range onto the target, Stepped in steps + 1 levels,
    Smooth Step and Smoother Step as their polynomials (a reversed source range reversed);
    Clamp holds a Linear result inside the target range, reversed or not; an empty source
    range gives a float 0 and a vector the target minimum."""
    for _ in range(20):
        x, a, b, c, d = rng.uniform(-1, 2, 5)
        t = (x - a) / (b - a)
        s = min(max(t, 0.0), 1.0)
        want = {"LINEAR": c + t * (d - c),
                "STEPPED": c + math.floor(t * 4.0) / 3.0 * (d - c),
                "SMOOTHSTEP": c + s * s * (3 - 2 * s) * (d - c),
                "SMOOTHERSTEP": c + s ** 3 * (s * (6 * s - 15) + 10) * (d - c)}
        for kind, w in want.items():
            got = _map_range(kind, x, (a, b, c, d), steps=3.0, width=width)
            np.testing.assert_allclose(got, w, atol=1e-12)
        lo, hi = min(c, d), max(c, d)
        np.testing.assert_allclose(_map_range("LINEAR", x, (a, b, c, d), clamp=True,
                                              width=width), min(max(c + t * (d - c), lo), hi),
                                   atol=1e-12)
    empty = 0.0 if width == 1 else 0.25
    np.testing.assert_allclose(_map_range("LINEAR", 0.7, (0.5, 0.5, 0.25, 0.9), width=width),
                               empty)


def test_clamp_and_ramp_extrapolation():
    """Clamp: Min Max is min(max(x, lo), hi) even reversed (then hi); Range turns a reversed
    range round. A table read past its ends continues the end entries' slope only when
    extrapolating, else holds them."""
    for x, lo, hi, swap, want in ((0.5, 0.2, 0.8, 0, 0.5), (1.5, 0.2, 0.8, 1, 0.8),
                                  (0.5, 0.8, 0.2, 0, 0.2), (0.5, 0.8, 0.2, 1, 0.5),
                                  (0.1, 0.8, 0.2, 1, 0.2)):
        assert shading.clamp_range(x, lo, hi, swap) == want
    table = np.zeros(4 * 5)
    table[0::4] = [0.0, 0.1, 0.3, 0.6, 1.0]  # red: slopes 0.4 per step at the end
    assert shading.ramp_lookup(table, 0, 5, 1.25, 0, True, True) == pytest.approx(1.0 + 0.4)
    assert shading.ramp_lookup(table, 0, 5, -0.5, 0, True, True) == pytest.approx(-0.2)
    assert shading.ramp_lookup(table, 0, 5, 1.25, 0, True, False) == 1.0
    assert shading.ramp_lookup(table, 0, 5, 0.375, 0, True, False) == pytest.approx(0.2)
    assert shading.ramp_lookup(table, 0, 5, 0.375, 0, False, False) == pytest.approx(0.1)


def _rotate(kind, vec, centre=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), angle=0.0,
            euler=(0.0, 0.0, 0.0), invert=False):
    prog = Program()
    regs = [prog.const(list(x)) for x in (vec, centre, axis)]
    angle_reg, euler_reg = prog.const([angle]), prog.const(list(euler))
    out = prog.emit(shading.OP_VECTOR_ROTATE, 3, *regs, d=shading.ROTATIONS.index(kind),
                    e=angle_reg, params=[int(invert), euler_reg])
    return shading.evaluate(prog)[out:out + 3]


def test_vector_rotate_of_each_type(rng):
    """Vector Rotate turns about the centre: about X, Y, Z as the Euler rotation of that
    one angle, about an axis as about its normalised self, by Euler angles as the Mapping's
    rotation; inverting undoes each; a zero axis leaves the vector."""
    for _ in range(10):
        v, c = rng.normal(size=3), rng.normal(size=3)
        angle, euler = rng.uniform(-3, 3), rng.uniform(-3, 3, 3)
        for k, kind in enumerate(("X_AXIS", "Y_AXIS", "Z_AXIS")):
            angles = np.zeros(3)
            angles[k] = angle
            want = _rotation(*angles) @ (v - c) + c
            np.testing.assert_allclose(_rotate(kind, v, c, angle=angle), want, atol=1e-12)
            axis = np.eye(3)[k] * 2.5
            np.testing.assert_allclose(_rotate("AXIS_ANGLE", v, c, axis, angle), want,
                                       atol=1e-12)
        np.testing.assert_allclose(_rotate("EULER_XYZ", v, c, euler=euler),
                                   _rotation(*euler) @ (v - c) + c, atol=1e-12)
        axis = rng.normal(size=3)
        turned = _rotate("AXIS_ANGLE", v, c, axis, angle)
        np.testing.assert_allclose(_rotate("AXIS_ANGLE", turned, c, axis, angle, invert=True),
                                   v, atol=1e-12)
        turned = _rotate("EULER_XYZ", v, c, euler=euler)
        np.testing.assert_allclose(_rotate("EULER_XYZ", turned, c, euler=euler, invert=True),
                                   v, atol=1e-12)
    np.testing.assert_allclose(_rotate("AXIS_ANGLE", (1.0, 2.0, 3.0), axis=(0.0, 0.0, 0.0),
                                       angle=1.0), (1.0, 2.0, 3.0))
