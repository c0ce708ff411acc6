"""Brush strokes: dabs placed on the surface by their 3-D position, in layers, drawn at the texels."""

import numpy as np
import pytest

from cp_stylize import Band, Sphere
from cp_stylize.atlas import uv_atlas
from cp_stylize.baking import atlas_points, texel_lengths
from cp_stylize.mesh import TriangleMesh, parametric_mesh
from cp_stylize import canvas, strokes
from cp_stylize.canvas import Texels, paint
from cp_stylize.stroke_field import StrokeField, Swirls
from cp_stylize.strokes import Brush, Dabs, place_dabs


@pytest.fixture(scope="module")
def sphere():
    """A UV sphere (seam at u = 0), its band, its own atlas and the atlas's texels."""
    vertices, faces, uvs = parametric_mesh(Sphere().point, 96, 48, periodic_u=True)
    mesh = TriangleMesh(vertices, faces)
    band = Band.build(mesh, 0.04)
    atlas = uv_atlas(mesh, 256, uvs)
    flat, points, face, bary = atlas_points(mesh, atlas, 4)
    texels = Texels(points, mesh.normal(points, face, bary), mesh.piece[face], texel_lengths(mesh, atlas, face), flat,
                    len(atlas.texels), atlas.size, atlas.uvs, mesh.vertices[mesh.input_faces])
    return mesh, band, atlas, texels


def _stripes(band, along):
    """Band colours striped across ``along`` (unit 3-vector): stripes run at right angles to it."""
    t = np.sin(40 * band.cp @ np.asarray(along, float))
    return np.column_stack([0.5 + 0.4 * t, 0.5 - 0.4 * t, 0.5 + 0 * t]).astype(np.float32)


def _one_dab(mesh, centre, direction, length=0.3, width=0.08, colour=(1.0, 0.0, 0.0)):
    from cp_stylize.mesh import TriangleMesh  # noqa: F401  (the mesh gives the face and barycentrics)

    cp, _, face, bary = mesh.closest_point_on_faces(np.atleast_2d(centre))
    n = mesh.normal(cp, face, bary)
    d = np.asarray(direction, float) - (np.asarray(direction, float) @ n[0]) * n[0]
    d /= np.linalg.norm(d)
    return Dabs(cp, n, d[None], np.array([length]), np.array([width]), np.array([colour]),
                mesh.piece[face].astype(np.int64), np.zeros(1), np.zeros(1, int), face, bary)


def test_the_stroke_field_runs_along_stripes(sphere):
    mesh, band, _, _ = sphere
    (field,) = StrokeField.layers(band, _stripes(band, [0, 0, 1]), [0.2])
    # stripes across z: strokes along the parallels, at right angles to z, where the stripes are
    equator = np.abs(band.cp[:, 2]) < 0.5
    assert np.median(np.abs(field.direction[equator, 2])) < 0.1
    assert np.median(field.confidence[equator]) > 0.5


def test_swirls_are_unit_tangents_that_turn():
    swirls = Swirls(0.5, seed=1)
    rng = np.random.default_rng(0)
    n = rng.standard_normal((2000, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    e = swirls(n, n)
    np.testing.assert_allclose(np.linalg.norm(e, axis=1), 1.0, atol=1e-9)
    np.testing.assert_allclose(np.einsum("ij,ij->i", e, n), 0.0, atol=1e-9)
    # nearby points circle together; far ones do not share a direction
    near = swirls(n + 0.01 * np.cross(n, e), n)
    assert np.median(np.abs(np.einsum("ij,ij->i", e, near))) > 0.95


def test_dabs_are_three_to_five_times_longer_than_wide_and_finer_layers_go_to_detail(sphere):
    mesh, band, atlas, texels = sphere
    colours = _stripes(band, [0, 0, 1])
    colours[band.cp[:, 0] < 0] = 0.5               # the half x < 0 is flat grey: no detail there
    brush = Brush(width=0.12, length=0.48, layers=2, seed=3)
    dabs = place_dabs(mesh, band, colours, brush, texel=float(np.median(texels.lengths)))
    assert np.all((dabs.aspect >= 3) & (dabs.aspect <= 5))
    first, fine = dabs.layer == 0, dabs.layer == 1
    assert np.mean(dabs.centre[first, 0] < 0) == pytest.approx(0.5, abs=0.1)       # the first layer everywhere
    reach = brush.widths(0.01)[1] / 2             # a finer dab sees the detail within its half width
    assert np.mean(dabs.centre[fine, 0] > -reach) > 0.8                              # finer dabs at the detail
    assert np.mean(dabs.centre[fine, 0] > 0) > 0.7
    np.testing.assert_allclose(np.linalg.norm(dabs.centre, axis=1), 1.0, atol=2e-3)  # on the surface
    np.testing.assert_array_equal(place_dabs(mesh, band, colours, brush, texel=0.01).centre[:50],
                                  place_dabs(mesh, band, colours, brush, texel=0.01).centre[:50])   # seeded


def test_a_dab_across_the_seam_is_drawn_whole_on_both_islands(sphere):
    mesh, band, atlas, texels = sphere
    # the UV sphere's seam (u = 0) is the meridian through (-1, 0, 0): a dab across it
    dab = _one_dab(mesh, [-1.0, 0.0, 0.2], [0, 1, 0])
    base = np.full((len(texels.points), 3), 0.5)
    out, height = paint(dab, texels, base, np.tile(dab.colour, (len(base), 1)))
    coverage = np.linalg.norm(out - base, axis=1) / np.linalg.norm(dab.colour[0] - base[0])
    painted = coverage > 0.5
    covered = painted[:texels.covered]
    u = (texels.flat[:texels.covered][covered] % atlas.size + 0.5) / atlas.size
    assert (u < 0.1).any() and (u > 0.9).any()                       # on both sides of the seam
    area = np.sum(coverage[:texels.covered] * texels.lengths[:texels.covered] ** 2)
    assert area == pytest.approx(0.3 * 0.08 * 0.79, rel=0.1)         # and whole, not cut at the seam
    assert np.all(height[~painted] < 0.5) and np.all(height[painted & (np.arange(len(out)) < texels.covered)] > 0)


def test_dab_edges_are_anti_aliased_and_overlaps_stack(sphere):
    mesh, band, atlas, texels = sphere
    one = _one_dab(mesh, [0.0, -1.0, 0.0], [0, 0, 1], length=0.6, width=0.2, colour=(0.9, 0.1, 0.1))
    base = np.zeros((len(texels.points), 3))
    reference = np.tile(one.colour, (len(base), 1))                  # the dab's own colour: nothing clips it
    out, height = paint(one, texels, base, reference)
    red = out[:, 0]
    partial = (red > 0.05) & (red < 0.6)
    assert partial.sum() > 10                                        # a rim of partly covered texels
    assert partial.sum() < (red >= 0.75).sum()                       # and a body
    two = Dabs.concatenate([one, _one_dab(mesh, [0.0, -1.0, 0.1], [0, 0, 1], length=0.6, width=0.2,
                                          colour=(0.9, 0.1, 0.5))])
    _, stacked = paint(two, texels, base, reference + [[0.0, 0.0, 0.4]])
    both = (height > 0) & (stacked > 0)
    assert stacked.max() > height.max()                              # paint piles up where dabs overlap
    assert np.all(stacked[both] > 0)


def test_a_dab_stops_at_an_edge_of_other_colours(sphere):
    mesh, band, atlas, texels = sphere
    dab = _one_dab(mesh, [0.0, -1.0, 0.0], [0, 0, 1], colour=(0.9, 0.9, 0.1))
    base = np.full((len(texels.points), 3), 0.9)
    base[:, 2] = 0.1
    reference = base.copy()
    reference[texels.points[:, 2] > 0.03] = (0.05, 0.05, 0.4)         # dark blue above z = 0.03
    out, _ = paint(dab, texels, base, reference)
    changed = np.linalg.norm(out - base, axis=1) > 0.05
    assert not np.any(changed & (texels.points[:, 2] > 0.06))         # the yellow dab keeps off the blue


def test_painting_reports_progress_and_stops_when_told(sphere):
    mesh, band, atlas, texels = sphere
    brush = Brush(width=0.06, length=0.24, layers=1, seed=1)
    dabs = place_dabs(mesh, band, np.full((band.size, 3), 0.5, np.float32), brush, texel=0.01)
    seen = []
    paint(dabs, texels, np.zeros((len(texels.points), 3)), progress=seen.append)
    assert seen == sorted(seen) and seen[-1] == 1.0

    def stop(fraction):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        paint(dabs, texels, np.zeros((len(texels.points), 3)), progress=stop)


def test_painting_draws_the_dabs_in_blocks_of_bounded_size_with_the_same_result(sphere, monkeypatch):
    mesh, band, atlas, texels = sphere
    brush = Brush(width=0.12, length=0.45, layers=2, seed=2)
    dabs = place_dabs(mesh, band, _stripes(band, [0, 0, 1]), brush, texel=0.01)
    base = np.zeros((len(texels.points), 3))
    whole = paint(dabs, texels, base)
    axes = canvas._uv_axes(dabs, texels)[0]
    monkeypatch.setattr(canvas, "_PAIRS", 2000)                    # a few dabs a block
    spans = canvas._blocks(axes)
    assert spans[0][0] == 0 and spans[-1][1] == len(dabs)
    assert all(a[1] == b[0] for a, b in zip(spans, spans[1:]))      # every dab once, in order
    sides = 2.0 * np.linalg.norm(canvas._grown(axes), axis=2)     # the sides of each dab's UV raster
    pairs = sides[:, 0] * sides[:, 1]
    assert len(spans) > 20
    assert all(stop - start == 1 or pairs[start:stop].sum() <= 2000 for start, stop in spans)
    small = paint(dabs, texels, base)
    for a, b in zip(whole, small):
        assert np.allclose(a, b, atol=1e-5)                          # the blocks composite to the same paint


def test_dabs_keep_a_direction_where_a_given_field_has_none(sphere):
    mesh, band, atlas, texels = sphere
    colours = _stripes(band, [0, 0, 1])
    brush = Brush(width=0.12, length=0.48, layers=1, seed=3)
    nothing = np.zeros((band.size, 3))                          # a field of no confidence anywhere (a flat part)
    dabs = place_dabs(mesh, band, colours, brush, texel=0.01, field=nothing)
    np.testing.assert_allclose(np.linalg.norm(dabs.direction, axis=1), 1.0, atol=1e-9)
    np.testing.assert_allclose(np.einsum("ij,ij->i", dabs.direction, dabs.normal), 0.0, atol=1e-9)
    plain = place_dabs(mesh, band, colours, brush, texel=0.01)
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", dabs.direction, plain.direction)), 1.0, atol=1e-9)


def test_the_form_field_runs_along_the_axis_where_the_form_has_no_direction(sphere):
    from cp_stylize.stroke_field import FALLBACK_TRUST, form_field

    mesh, band, atlas, texels = sphere
    n = band.cp / np.linalg.norm(band.cp, axis=1, keepdims=True)
    equator = np.abs(n[:, 2]) < 0.5
    along = form_field(band, np.zeros((band.size, 3)))                 # a sphere: no principal direction
    length = np.linalg.norm(along, axis=1)
    assert np.median(np.abs(along[equator, 2]) / length[equator]) > 0.85   # the meridians: along z
    # ... as a fallback, trusted at half, which a sure structure of the picture overrules
    assert np.all(length <= FALLBACK_TRUST + 1e-9) and np.median(length[equator]) > 0.9 * FALLBACK_TRUST
    around = form_field(band, np.zeros((band.size, 3)), around=True)
    assert np.median(np.abs(around[equator, 2]) / length[equator]) < 0.05  # the parallels: across z
    given = np.cross(n, [0.0, 0.0, 1.0])                               # a sure field is kept as it is
    given /= np.linalg.norm(given, axis=1, keepdims=True)
    kept = form_field(band, given)
    assert np.median(np.abs(np.einsum("ij,ij->i", kept[equator], given[equator]))) > 0.99


def test_the_around_direction_runs_the_parallels_of_its_axis(sphere):
    from cp_stylize.pipeline import stroke_field
    from cp_stylize.presets import StylizeSettings
    from cp_stylize.stroke_field import FALLBACK_TRUST

    mesh, band, atlas, texels = sphere
    n = band.cp / np.linalg.norm(band.cp, axis=1, keepdims=True)
    axis = np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0)                     # any axis in the object's space
    settings = StylizeSettings(mode="eed", direction="around", axis=tuple(axis), hatch_spacing=0.05)
    field = stroke_field(band, settings)
    length = np.linalg.norm(field, axis=1)
    belt = np.abs(n @ axis) < 0.5                                        # the axis's equator and near it
    unit = field[belt] / length[belt, None]
    assert np.median(np.abs(unit @ axis)) < 0.05                        # across the axis: its parallels
    assert np.median(np.abs(np.einsum("ij,ij->i", unit, n[belt]))) < 0.05   # on the surface
    assert np.median(length[belt]) > 0.9 * FALLBACK_TRUST and np.all(length <= FALLBACK_TRUST + 1e-9)
    pole = np.abs(n @ axis) > 0.999                                      # facing the axis: no direction
    assert pole.any() and np.all(length[pole] < 0.1 * FALLBACK_TRUST)


def test_a_fallback_field_yields_to_the_pictures_structure_and_a_sure_one_does_not(sphere, monkeypatch):
    from cp_stylize import strokes

    mesh, band, atlas, texels = sphere
    monkeypatch.setattr(strokes, "FILLS", 0)        # no filling dabs, which go where each field's strokes left gaps
    colours = _stripes(band, [0, 0, 1])                    # stripes round the z axis: strokes run around it
    brush = Brush(width=0.12, length=0.48, layers=1, chain=1, seed=3)   # single dabs: the same centres whatever
    #                                                                   the field
    n = band.cp / np.linalg.norm(band.cp, axis=1, keepdims=True)
    meridians = np.array([0.0, 0.0, 1.0]) - n[:, 2:3] * n
    meridians /= np.maximum(np.linalg.norm(meridians, axis=1, keepdims=True), 1e-12)
    plain = place_dabs(mesh, band, colours, brush, texel=0.01)
    unsure = place_dabs(mesh, band, colours, brush, texel=0.01, field=0.5 * meridians)
    sure = place_dabs(mesh, band, colours, brush, texel=0.01, field=meridians)
    equator = np.abs(plain.centre[:, 2]) < 0.5
    along = lambda dabs: np.abs(np.einsum("ij,ij->i", dabs.direction, plain.direction))[equator]
    assert np.median(along(unsure)) > 0.95                 # the stripes win over a half-trusted field
    assert np.median(np.abs(sure.direction[equator, 2])) > 0.95     # a sure field wins over the stripes


def test_swirls_turn_strokes_in_the_light_and_leave_the_dark_calm(sphere, monkeypatch):
    from cp_stylize import strokes
    from cp_stylize.oklab import to_oklab

    mesh, band, atlas, texels = sphere
    monkeypatch.setattr(strokes, "FILLS", 0)        # no filling dabs, which go where each field's strokes left gaps
    for grey, calm in ((0.08, True), (0.85, False)):
        colours = np.full((band.size, 3), grey, np.float32)
        colours += 0.01 * np.random.default_rng(2).random(colours.shape, np.float32)   # no structure: noise
        assert (to_oklab(colours[:1])[0, 0] < 0.45) == calm
        kw = dict(texel=0.01)
        # single dabs (chain 1): the same centres whatever the field
        straight = place_dabs(mesh, band, colours, Brush(width=0.08, length=0.3, layers=1, chain=1, seed=5), **kw)
        swirled = place_dabs(mesh, band, colours, Brush(width=0.08, length=0.3, layers=1, chain=1, seed=5, swirl=1.0),
                             **kw)
        np.testing.assert_array_equal(straight.centre, swirled.centre)
        agree = np.abs(np.einsum("ij,ij->i", straight.direction, swirled.direction))
        if calm:
            np.testing.assert_allclose(agree, 1.0, atol=1e-6)
        else:
            assert np.mean(agree < 0.9) > 0.3


def test_a_dabs_paint_stands_with_a_rim_along_its_sides_and_ends_within_a_short_edge(sphere):
    mesh, band, atlas, texels = sphere
    one = _one_dab(mesh, [0.0, -1.0, 0.0], [0, 0, 1], length=0.8, width=0.4)   # 16 texels wide
    base = np.zeros((len(texels.points), 3))
    out, height = paint(one, texels, base, np.tile(one.colour, (len(base), 1)))
    across = np.abs(texels.points @ np.cross(one.normal[0], one.direction[0]))
    signed = (texels.points - one.centre[0]) @ one.direction[0]     # from the centre towards the tail
    along = np.abs(signed)
    front = texels.points[:, 1] < -0.5                               # the dab's side of the sphere
    middle = front & (along < 0.1)                                   # across the dab's middle
    body = height[middle & (across < 0.05)]
    assert body.min() > 0.25 * height.max()       # its body stands, bristle furrows and all (the head and rims stand highest)
    rim = height[middle & (np.abs(across - 0.2 * canvas.RIM_AT) < 0.01)]   # the rim's crest
    assert len(rim) > 2 and rim.mean() > 1.1 * body.mean()           # paint pushed aside: a rim along its sides
    head = height[front & (np.abs(signed + 0.7 * 0.4) < 0.03) & (across < 0.05)]   # 0.7 of the half length (0.4) headwards
    assert len(head) > 2 and head.mean() > 1.5 * body.mean()         # and a blob where the brush touched down
    # the paint ends within EDGE of its half width (and a texel): none beyond the dab's edge
    beyond = middle & (across > 0.2 + np.max(texels.lengths))
    assert beyond.sum() > 5 and not np.any(height[beyond] > 0)
    ramp = middle & (across > 0.2 * (1.0 - canvas.EDGE)) & (across < 0.2)
    assert ramp.sum() > 2 and height[ramp].min() < rim.min()


def test_finer_dabs_go_to_an_edge_the_broad_ones_cannot_carry_not_over_a_texture_finer_than_both(sphere):
    mesh, band, atlas, texels = sphere
    colours = 0.5 + 0.25 * (_stripes(band, [0, 0, 1]) - 0.5)   # faint stripes 0.16 apart: finer than either brush
    y = band.cp[:, 1]
    colours[y > 0.3] = 0.1                                    # and one edge, at y = 0.3
    found = {}
    for broad in (0.0, 1.0):
        brush = Brush(width=0.3, length=1.2, layers=2, seed=3, broad=broad)
        dabs = place_dabs(mesh, band, colours, brush, texel=float(np.median(texels.lengths)))
        fine, at = dabs.layer == 1, dabs.centre[:, 1]
        edge, striped = fine & (np.abs(at - 0.3) < 0.2), fine & (at < -0.3)
        density = (edge.sum() / np.sum(np.abs(y - 0.3) < 0.2)) / max(striped.sum() / np.sum(y < -0.3), 1e-9)
        found[broad] = edge.sum(), striped.sum(), density
    (edge_0, striped_0, _), (edge_1, striped_1, density_1) = found[0.0], found[1.0]
    assert striped_1 < 0.35 * striped_0             # broad paint leaves the faint stripes to the broad strokes ...
    assert edge_1 >= 10 and edge_1 > 0.35 * edge_0  # ... and keeps finer strokes at the edge,
    assert density_1 > 2.0                          # where they crowd


def test_a_finer_layers_paint_is_thinner_and_lies_on_the_broad_paint_under_it(sphere):
    mesh, band, atlas, texels = sphere
    broad = _one_dab(mesh, [0.0, -1.0, 0.0], [0, 0, 1], length=0.8, width=0.4)     # 16 texels wide
    elsewhere = _one_dab(mesh, [0.0, 1.0, 0.0], [0, 0, 1], length=0.8, width=0.4)
    fine = _one_dab(mesh, [0.0, -1.0, 0.0], [1, 0, 0], length=0.35, width=0.1)   # across it, 4 texels wide
    fine.layer[:] = 1
    for dab in (broad, elsewhere, fine):
        dab.ends = np.zeros(1, np.int8)                              # each within its stroke
    base = np.zeros((len(texels.points), 3))
    reference = np.tile(broad.colour, (len(base), 1))

    def height(*dabs):
        return paint(Dabs.concatenate(list(dabs)), texels, base, reference)[1]

    alone = height(broad)
    thin = height(elsewhere, fine)                                   # the fine dab alone on this side
    both = height(broad, fine)
    x, z = texels.points[:, 0], texels.points[:, 2]
    front = texels.points[:, 1] < -0.5
    core = front & (np.abs(z) < 0.02) & (np.abs(x) < 0.1)                 # the middle of the fine dab
    body = front & (np.abs(x) < 0.05) & (np.abs(z) < 0.1)                 # and of the broad one
    assert core.sum() > 5 and body.sum() > 20
    # a brush a quarter as wide carries far thinner paint (FINE_PAINT; its one crest stands a little above
    # its body), so its flanks are no steeper than the broad one's
    ratio = np.mean(thin[core]) / np.mean(alone[body])
    assert (0.1 / 0.4) ** canvas.FINE_PAINT * 0.8 < ratio < (0.1 / 0.4) ** canvas.FINE_PAINT * 1.5
    # and it lies on the broad stroke's paint, as a stroke's first dab does, instead of scraping it away
    assert np.mean(both[core]) > (1.0 - canvas.FLATTEN) * np.mean(alone[core]) + 0.8 * np.mean(thin[core])


def test_the_first_layers_dabs_make_long_strokes_along_the_field_that_stop_at_a_colour_edge(sphere):
    mesh, band, atlas, texels = sphere
    colours = _stripes(band, [0, 0, 1])                       # strokes run round the z axis, along the stripes
    colours[band.cp[:, 0] > 0.3] = [0.1, 0.1, 0.9]            # a flat blue cap: no stroke runs into or out of it
    dabs = place_dabs(mesh, band, colours, Brush(width=0.06, length=0.24, layers=1, seed=4), texel=0.01)
    # a stroke's dabs follow one another and share their paint: the same jitter draws and bristles
    same = np.all(dabs.draws[1:] == dabs.draws[:-1], axis=1) & (dabs.phase[1:] == dabs.phase[:-1])
    step = np.linalg.norm(dabs.centre[1:] - dabs.centre[:-1], axis=1)
    assert 0.4 * len(dabs) < same.sum() < len(dabs)
    # the next dab's centre is the band point nearest to that step on: within a grid spacing of it
    np.testing.assert_allclose(step[same], strokes.CHAIN_STEP * dabs.length[:-1][same], rtol=0, atol=band.h)
    turn = np.abs(np.einsum("ij,ij->i", dabs.direction[1:], dabs.direction[:-1]))[same]
    assert np.median(turn) > 0.95                             # each dab goes on along the last one's direction
    cap = dabs.centre[:, 0] > 0.3
    assert not np.any(same & (cap[1:] != cap[:-1]))           # no stroke crosses the cap's edge


def test_a_finer_layer_lays_its_dabs_in_strokes_of_a_share_of_the_chain(sphere):
    assert [strokes.chain_links(8, layer) for layer in range(4)] == [8, 4, 2, 2]
    assert [strokes.chain_links(3, layer) for layer in range(3)] == [3, 1, 1]     # short strokes: single fine dabs
    mesh, band, atlas, texels = sphere
    colours = _stripes(band, [0, 0, 1])                       # detail everywhere: the second layer covers it too

    def strokes_of(chain):
        dabs = place_dabs(mesh, band, colours, Brush(width=0.1, length=0.4, layers=2, chain=chain, seed=4), texel=0.005)
        heads = dabs.heads[dabs.layer == 1]
        return heads.size / heads.sum()                       # the second layer's dabs a stroke, on average

    long, single = strokes_of(8), strokes_of(3)
    print(f"\nthe second layer's dabs a stroke: {long:.2f} with a chain of 8, {single:.2f} with 3")
    assert single == 1.0 and 1.5 < long <= 4.0


def test_a_dab_bends_with_a_field_that_turns_and_is_straight_where_it_does_not(sphere):
    mesh, band, atlas, texels = sphere
    x = band.cp
    straight = np.column_stack([-x[:, 1], x[:, 0], 0 * x[:, 0]])       # the parallels: round the z axis
    field = straight / np.maximum(np.linalg.norm(straight, axis=1, keepdims=True), 1e-12)
    flat = np.full((band.size, 3), 0.5, np.float32)
    dabs = place_dabs(mesh, band, flat, Brush(width=0.06, length=0.3, layers=1, seed=2), texel=0.01, field=field)
    # a parallel at latitude phi turns towards the pole at tan(phi) per unit length (its geodesic curvature)
    z = dabs.centre[:, 2]
    side = np.cross(dabs.normal, dabs.direction)
    expected = np.sign(side[:, 2]) * z / np.sqrt(1 - z**2)
    low = np.abs(z) < 0.5
    np.testing.assert_allclose(dabs.bend[low], expected[low], atol=0.35)
    assert np.median(np.abs(dabs.bend[np.abs(z) < 0.1])) < 0.2


def _chained_pair(mesh, ends, length=0.6, width=0.2):
    """Two dabs laid along z one after another, as a stroke's dabs are (:data:`strokes.CHAIN_STEP` apart), with
    the same paint, and the given ``ends`` flags."""
    step = strokes.CHAIN_STEP * length
    two = Dabs.concatenate([_one_dab(mesh, [0.0, -1.0, -0.5 * step], [0, 0, 1], length, width),
                            _one_dab(mesh, [0.0, -1.0, 0.5 * step], [0, 0, 1], length, width)])
    two.ends = np.asarray(ends, np.int8)
    return two


def test_a_strokes_dabs_have_one_head_and_one_tail_and_run_on_into_one_another(sphere):
    mesh, band, atlas, texels = sphere
    colours = _stripes(band, [0, 0, 1])
    dabs = place_dabs(mesh, band, colours, Brush(width=0.06, length=0.24, layers=2, seed=4), texel=0.01)
    first = dabs.layer == 0
    same = (np.all(dabs.draws[1:] == dabs.draws[:-1], axis=1) & (dabs.phase[1:] == dabs.phase[:-1])
            & first[1:] & first[:-1])
    assert same.sum() > 0.3 * first.sum()
    assert not np.any(dabs.tails[:-1][same]) and not np.any(dabs.heads[1:][same])   # within a stroke: no ends
    assert np.all(dabs.heads[1:][~same]) and np.all(dabs.tails[:-1][~same])          # and each stroke has both
    assert np.all(dabs.heads[~first] & dabs.tails[~first])                           # finer dabs stand alone
    # drawn, the second dab lays its paint over the first's: no ridge where its head lies on the first's body
    front = texels.points[:, 1] < -0.5
    middle = front & (np.abs(texels.points @ [1.0, 0.0, 0.0]) < 0.03)
    base = np.zeros((len(texels.points), 3))
    reference = np.tile([[1.0, 0.0, 0.0]], (len(base), 1))
    head_of_second = middle & (np.abs(texels.points[:, 2] - (0.5 * strokes.CHAIN_STEP - 0.5) * 0.6) < 0.06)
    body_of_first = middle & (np.abs(texels.points[:, 2] + 0.5 * strokes.CHAIN_STEP * 0.6) < 0.06)
    _, one_stroke = paint(_chained_pair(mesh, [canvas.HEAD_END, canvas.TAIL_END]), texels, base, reference)
    _, two_strokes = paint(_chained_pair(mesh, [3, 3]), texels, base, reference)
    assert one_stroke[head_of_second].max() < 1.1 * one_stroke[body_of_first].max()
    assert two_strokes[head_of_second].max() > 1.3 * two_strokes[body_of_first].max()   # two strokes pile up


def test_a_strokes_last_dab_runs_dry_along_its_bristles_and_the_others_do_not(sphere):
    mesh, band, atlas, texels = sphere
    base = np.zeros((len(texels.points), 3))
    reference = np.tile([[1.0, 0.0, 0.0]], (len(base), 1))
    front = texels.points[:, 1] < -0.5
    across = np.abs(texels.points[:, 0])
    along = texels.points[:, 2] / 0.4                                 # the dab's half length is 0.4
    covered = {}
    for ends in (canvas.HEAD_END, canvas.HEAD_END | canvas.TAIL_END):
        dab = _one_dab(mesh, [0.0, -1.0, 0.0], [0, 0, 1], length=0.8, width=0.4)
        dab.ends = np.array([ends], np.int8)
        out, _ = paint(dab, texels, base, reference)
        covered[ends] = out[:, 0]
    body = front & (np.abs(along) < 0.3) & (across < 0.1)
    tail = front & (along > 0.75) & (along < 0.85) & (across < 0.1)
    for red in covered.values():
        assert red[body].min() > 0.8                                  # the body is covered
    assert covered[canvas.HEAD_END][tail].min() > 0.8                # a dab that goes on is covered to its tail
    dry = covered[canvas.HEAD_END | canvas.TAIL_END][tail]
    assert dry.min() < 0.3 and dry.max() > 0.8                        # the stroke's end breaks up: gaps and paint
    # ... and its paint thins out evenly: no raised fingers along the bristles, which a light draws as ticks
    dab.ends = np.array([canvas.HEAD_END | canvas.TAIL_END], np.int8)
    _, height = paint(dab, texels, base, reference)
    red = covered[canvas.HEAD_END | canvas.TAIL_END]
    gaps, streaks = tail & (red < 0.3), tail & (red > 0.8)
    assert gaps.sum() > 3 and streaks.sum() > 3
    assert height[gaps].mean() > 0.7 * height[streaks].mean()
    assert height[tail].max() < 0.5 * height[body].mean()             # thinner at the tail


def _footprint(dab, points):
    """Where ``points`` lie in a single dab's tapered footprint: its outline at 1 (and its place along it)."""
    offset = points - dab.centre[0]
    along = (offset @ dab.direction[0]) / (0.5 * dab.length[0])
    side = np.cross(dab.normal[0], dab.direction[0])
    half = 0.5 * dab.width[0] * canvas._half_width(np.clip(along, -1.0, 1.0))
    return np.maximum(np.abs(offset @ side) / np.maximum(half, 1e-9), np.abs(along)), along


def test_a_dab_within_a_stroke_stands_on_a_rounded_edge_all_round_its_footprint(sphere):
    mesh, band, atlas, texels = sphere
    base = np.zeros((len(texels.points), 3))
    dab = _one_dab(mesh, [0.0, -1.0, 0.0], [0, 0, 1], length=0.8, width=0.4)
    dab.ends = np.zeros(1, np.int8)                                  # neither its stroke's head nor its tail
    _, height = paint(dab, texels, base, np.tile(dab.colour, (len(base), 1)))
    outline, along = _footprint(dab, texels.points)
    front = texels.points[:, 1] < -0.5
    edge = front & (outline > 0.97) & (outline < 1.0)                 # just inside the outline, head and tail too
    head = edge & (along < -0.8)
    assert head.sum() > 3 and edge.sum() > 20
    assert height[edge].max() < 0.35 * np.median(height[front & (outline < 0.3)])   # no cliff where it ends


def test_a_dab_clipped_away_but_for_a_sliver_leaves_little_relief(sphere):
    mesh, band, atlas, texels = sphere
    base = np.zeros((len(texels.points), 3))
    dab = _one_dab(mesh, [0.0, -1.0, 0.0], [0, 0, 1], length=0.8, width=0.4)
    _, whole = paint(dab, texels, base, np.tile(dab.colour, (len(base), 1)))
    other = np.tile([[0.0, 0.0, 1.0]], (len(base), 1))
    sliver = texels.points[:, 0] > 0.15                               # its colour shows along one side alone
    other[sliver] = dab.colour[0]
    out, clipped = paint(dab, texels, base, other)
    shown = out[texels.points[:, 1] < -0.5, 0]
    assert 0.0 < np.mean(shown > 0.5) < 0.1
    assert clipped.max() < 0.5 * whole.max()


def test_a_dab_stops_where_the_picture_or_its_paint_changes(sphere):
    mesh, band, atlas, texels = sphere
    dab = _one_dab(mesh, [0.0, -1.0, 0.0], [0, 0, 1], length=0.8, width=0.4, colour=(0.3, 0.3, 0.3))
    base = np.zeros((len(texels.points), 3))
    grey = np.full_like(base, 0.3)
    marking = texels.points[:, 0] > 0.0          # a road's marking: a little lighter, in the palette's yellow
    picture, paint_of = grey.copy(), grey.copy()
    picture[marking], paint_of[marking] = 0.36, [0.95, 0.8, 0.1]
    covered = (texels.points[:, 1] < -0.9) & (np.abs(texels.points[:, 2]) < 0.15) & (np.abs(texels.points[:, 0]) < 0.15)
    alone, raised = paint(dab, texels, base, picture)                  # by the picture alone: painted over
    both, relief = paint(dab, texels, base, np.hstack([picture, paint_of]), source=np.array([[0.3, 0.3, 0.3] * 2]))
    left, right = covered & (texels.points[:, 0] < -0.05), covered & (texels.points[:, 0] > 0.05)
    assert alone[right, 0].min() > 0.25
    assert both[right].max() == 0.0 and both[left, 0].min() > 0.25     # stopped at the marking, whole elsewhere
    # the paint's relief keeps the dab's whole shape: no cliff where its colour stops
    np.testing.assert_array_equal(relief, raised)
    assert np.median(relief[right]) > 0.5 * np.median(relief[left]) > 0
    assert canvas.clipped(canvas.CLIP) == 1.0 and canvas.clipped(canvas.CLIP_GONE) == 0.0


def test_a_loaded_brush_lays_its_second_colour_along_one_side_in_streaks(sphere):
    mesh, band, atlas, texels = sphere
    dab = _one_dab(mesh, [0.0, -1.0, 0.0], [0, 0, 1], length=0.8, width=0.4, colour=(1.0, 0.0, 0.0))
    dab.second = np.array([[0.0, 0.0, 1.0]])
    dab.phase = np.array([0.3])
    base = np.zeros((len(texels.points), 3))
    out, _ = paint(dab, texels, base, np.tile([[0.9, 0.0, 0.2]], (len(base), 1)))
    front = texels.points[:, 1] < -0.5
    body = front & (np.abs(texels.points[:, 2]) < 0.1) & (np.abs(texels.points[:, 0]) < 0.15)
    blue = out[body, 2] / np.maximum(out[body, 0] + out[body, 2], 1e-9)
    assert np.mean(blue > 0.8) > 0.15 and np.mean(blue < 0.2) > 0.15     # both colours, each where it lies
    # the second colour's share changes across the stroke far more than along it
    x, z = texels.points[body, 0], texels.points[body, 2]
    assert abs(np.corrcoef(blue, x)[0, 1]) > 3 * abs(np.corrcoef(blue, z)[0, 1])


def test_flat_parts_of_the_picture_take_level_strokes_and_its_structure_keeps_its_own(sphere):
    from cp_stylize.stroke_field import level_field

    mesh, band, _, _ = sphere
    n = band.cp / np.linalg.norm(band.cp, axis=1, keepdims=True)
    meridians = np.array([0.0, 0.0, 1.0]) - n[:, 2:3] * n
    level = np.zeros((mesh.n_input_faces, 3))
    level[:] = [0.0, 0.0, 1.0]                          # the picture's horizontal: along the meridians
    field = level_field(band, None, level)
    equator = np.abs(band.cp[:, 2]) < 0.5
    from cp_stylize.tangent import surface_normals

    assert np.all(np.abs(np.einsum("ij,ij->i", field, surface_normals(band))) < 1e-5)     # in the tangent planes
    assert np.median(np.abs(np.einsum("ij,ij->i", field[equator], meridians[equator])
                            / np.linalg.norm(meridians[equator], axis=1))) > 0.99
    # where a given field has a direction, the level leaves it be
    given = np.zeros((band.size, 3))
    given[band.cp[:, 0] > 0] = meridians[band.cp[:, 0] > 0]
    kept = level_field(band, given, level)
    assert np.all(kept[band.cp[:, 0] > 0] == 0) and np.any(kept[band.cp[:, 0] < -0.1] != 0)
    brush = Brush(width=0.12, length=0.48, layers=1, chain=1, seed=3)
    grey = np.full((band.size, 3), 0.4, dtype=np.float32)
    flat = place_dabs(mesh, band, grey, brush, texel=0.01, level=field)           # no structure: level strokes
    near = np.abs(flat.centre[:, 2]) < 0.5
    assert np.median(np.abs(flat.direction[near, 2])) > 0.9
    striped = _stripes(band, [0, 0, 1])                 # stripes round z: their structure runs along the parallels
    sure = place_dabs(mesh, band, striped, brush, texel=0.01, level=field)
    near = np.abs(sure.centre[:, 2]) < 0.5
    assert np.median(np.abs(sure.direction[near, 2])) < 0.2


def test_a_swirling_brush_lays_no_level_strokes_and_the_level_yields_as_swirl_grows(sphere):
    from cp_stylize.stroke_field import LEVEL_SWIRL, level_field, level_share

    assert level_share(0.0) == 1.0 and level_share(0.5 * LEVEL_SWIRL) == 0.5 and level_share(0.6) == 0.0
    mesh, band, _, _ = sphere
    centres = np.asarray(mesh.vertices)[np.asarray(mesh.input_faces)].mean(axis=1)
    level = np.cross([0.0, 0.0, 1.0], centres)          # the picture's horizontal: along the parallels
    field = level_field(band, None, level)
    brush = Brush(width=0.12, length=0.48, layers=1, chain=1, seed=3)
    grey = np.full((band.size, 3), 0.4, dtype=np.float32)           # no structure anywhere

    def along_level(share):
        dabs = place_dabs(mesh, band, grey, brush, texel=0.01, level=share * field)
        near = np.abs(dabs.centre[:, 2]) < 0.5
        parallels = np.cross([0.0, 0.0, 1.0], dabs.centre[near])
        parallels /= np.linalg.norm(parallels, axis=1, keepdims=True)
        return np.median(np.abs(np.einsum("ij,ij->i", dabs.direction[near], parallels)))

    full, half, none = along_level(1.0), along_level(0.5), along_level(0.0)
    assert full > 0.9 and none < 0.8 and none < half < full


def test_the_pictures_horizontal_is_its_u_axis_on_each_face():
    from cp_stylize.sampling import ColourInput, Texture, picture_level

    vertices, faces, uvs = parametric_mesh(lambda u, v: np.stack([2 * u, v, 0 * u], axis=-1), 8, 4)
    mesh = TriangleMesh(vertices, faces)
    image = np.zeros((4, 4, 3), np.float32)
    some = np.arange(len(faces)) % 2 == 0
    level = picture_level(mesh, ColourInput(textures=[Texture(image, uvs, some)]))
    np.testing.assert_allclose(np.abs(level[some, 0]), 1.0, atol=1e-9)     # u runs along x
    assert np.all(level[~some] == 0)                                       # no picture there
    turned = picture_level(mesh, ColourInput(textures=[Texture(image, uvs[:, :, ::-1], some)]))
    np.testing.assert_allclose(np.abs(turned[some, 1]), 1.0, atol=1e-9)    # its u along y


def _plane_texels(size, normal_z=1.0):
    """Texels of a square atlas on the plane z = 0, one texel 0.01 long, the normal +z or -z."""
    row, column = np.divmod(np.arange(size * size), size)
    points = np.column_stack([0.01 * column, 0.01 * row, np.zeros(size * size)])
    normals = np.tile([0.0, 0.0, normal_z], (size * size, 1))
    return Texels(points, normals, np.zeros(size * size, int), np.full(size * size, 0.01), np.arange(size * size),
                  size * size, size, np.zeros((0, 3, 2)), np.zeros((0, 3, 3)))


def test_sheen_lights_the_flank_of_a_ridge_towards_the_form_light_and_shades_the_other(monkeypatch):
    from cp_stylize import painting
    from cp_stylize.hatching import LIGHT
    from cp_stylize.painting import SHEEN_LIGHT, SHEEN_SHADE, _sheen

    size = 96
    texels = _plane_texels(size)
    across = texels.points[:, :2] @ (LIGHT[:2] / np.linalg.norm(LIGHT[:2]))   # towards the light, on the plane
    middle = np.median(across)
    height = np.exp(-((across - middle) / 0.1) ** 2)                 # a ridge at right angles to the light
    painted = np.full((size * size, 3), 0.4)
    out = _sheen(painted, height, texels, 0.1, 1.0)[:, 0]
    toward, away = np.abs(across - middle - 0.07) < 0.01, np.abs(across - middle + 0.07) < 0.01
    far = np.abs(across - middle) > 0.35
    assert out[toward].min() > 0.45 and out[away].max() < 0.35       # its flank to the light lit, the other shaded,
    assert far.sum() > 1000 and np.allclose(out[far], 0.4, atol=1e-3)   # flat paint as it was
    assert np.all(out <= 0.4 + 0.6 * SHEEN_LIGHT + 1e-9) and np.all(out >= 0.4 * (1 - SHEEN_SHADE) - 1e-9)
    half = _sheen(painted, height, texels, 0.1, 0.5)[:, 0]
    assert np.allclose(half - 0.4, 0.5 * (out - 0.4))                 # the setting scales it
    assert np.array_equal(_sheen(painted, height, texels, 0.1, 0.0), painted)
    # a surface turned away from the light takes it from its own side: the relief reads there too, alike
    back = _sheen(painted, height, _plane_texels(size, -1.0), 0.1, 1.0)[:, 0]
    assert back[toward].min() > 0.45 and back[away].max() < 0.35
    # bristle grooves 2 * reach texels apart leave no mark in the light; the ridge they lie on still shows
    column = np.arange(size * size) % size
    combed = _sheen(painted, height + 0.3 * np.cos(np.pi * column / 2), texels, 0.1, 1.0, reach=2)[:, 0]
    plain = _sheen(painted, height, texels, 0.1, 1.0, reach=2)[:, 0]
    inside = (column >= 2) & (column < size - 2)
    assert np.allclose(combed[inside], plain[inside], atol=1e-9) and plain[toward].min() > 0.45
    assert np.abs(_sheen(painted, height + 0.3 * np.cos(np.pi * column / 2), texels, 0.1, 1.0)[:, 0]
                  - out)[inside].max() > 0.1                         # lit texel by texel, they would
    monkeypatch.setattr(painting, "SHEEN_CHUNK", 1000)               # a few texels at a time: the same
    assert np.allclose(_sheen(painted, height, texels, 0.1, 1.0)[:, 0], out, rtol=0, atol=1e-12)


def test_a_painting_with_sheen_lights_its_dabs_from_their_own_relief_and_changes_nothing_else(sphere):
    from cp_stylize.painting import Painting

    mesh, band, atlas, texels = sphere
    one = _one_dab(mesh, [0.0, -1.0, 0.0], [0, 0, 1], length=0.8, width=0.4, colour=(0.3, 0.3, 0.6))
    base = np.full((len(texels.points), 3), 0.5)
    where = (texels.flat, texels.points, *atlas_points(mesh, atlas, 4)[2:])
    plain, height = Painting(mesh, atlas, one)(where, base, None)
    lit, same = Painting(mesh, atlas, one, sheen=1.0)(where, base, None)
    assert np.array_equal(height, same)                              # the relief itself is as it was
    change = (lit - plain)[:, 2]
    assert (change > 0.01).sum() > 10 and (change < -0.01).sum() > 10   # light and shade on the dab,
    away = texels.points[:, 1] > -0.3                                # and none away from it
    assert away.sum() > 1000 and np.array_equal(lit[away], plain[away])


def _equator_line(sphere, half, **painting):
    """A light grey picture with a dark line ``2 * half`` wide along the sphere's equator, painted with one broad
    grey dab on the sphere's front and with ``painting`` (:class:`~cp_stylize.painting.Painting`'s keywords):
    the painted texels' colours and height."""
    from cp_stylize.painting import Painting

    mesh, band, atlas, texels = sphere
    one = _one_dab(mesh, [0.0, -1.0, 0.0], [0, 0, 1], length=0.8, width=0.4, colour=(0.7, 0.7, 0.7))
    corners = mesh.vertices[mesh.input_faces]

    def picture(faces, barys):
        z = np.einsum("nk,nk->n", barys, corners[faces][:, :, 2])
        return np.where(np.abs(z) < half, 0.15, 0.7)[:, None] * np.ones(3)

    base = np.full((len(texels.points), 3), 0.7)
    where = (texels.flat, texels.points, *atlas_points(mesh, atlas, 4)[2:])
    return Painting(mesh, atlas, one, source=picture, **painting)(where, base, None)


def test_the_pictures_thin_lines_are_laid_as_dabs_of_dark_paint_that_leave_relief(sphere):
    texels = sphere[3]
    plain, _ = _equator_line(sphere, 0.015)
    lined, height = _equator_line(sphere, 0.015, detail=0.4, fine=0.1)
    z, y = texels.points[:, 2], texels.points[:, 1]
    on, off = np.abs(z) < 0.008, np.abs(z) > 0.1
    assert on.sum() > 100 and (plain - lined)[on].mean() > 0.2          # the line is painted dark
    assert np.abs(lined - plain)[off].max() < 1e-6                      # and nothing away from it
    away = y > -0.5                                                      # far from the one dab
    assert np.mean(height[on & away] > 0) > 0.9 and np.all(height[off & away] == 0)   # its paint stands
    # a shade of the paint under it, not the ink's black: grey stays grey, a third of the way down
    assert np.abs(np.diff(lined[on & away], axis=1)).max() < 0.02 and lined[on & away].mean() > 0.25
    # at a low Detail a line as long as this one is laid fainter (and a short one not at all: test_rigger)
    faint, _ = _equator_line(sphere, 0.015, detail=0.15, fine=0.1)
    assert 0.05 < (plain - faint)[on].mean() < 0.7 * (plain - lined)[on].mean()


def test_the_last_passes_of_fine_dabs_leave_no_bare_canvas_between_the_strokes(sphere, monkeypatch):
    from cp_stylize import strokes
    from cp_stylize.strokes import _bare

    mesh, band, _, _ = sphere
    grey = np.full((band.size, 3), 0.5)
    points = mesh.sample(3000, np.random.default_rng(1))[0]
    brush = Brush(width=0.12, length=0.5, layers=1, chain=3)

    def bare():
        return np.mean(_bare([place_dabs(mesh, band, grey, brush, texel=0.01)], points) > 0.5)

    filled = bare()
    monkeypatch.setattr(strokes, "FILLS", 0)
    assert filled < 0.025 and bare() > 0.04            # random strokes alone leave gaps; the fill closes them


def test_a_swirling_brush_lays_no_level_strokes_even_on_the_pictures_dark_ground(sphere):
    from cp_stylize.pipeline import stroke_level
    from cp_stylize.sampling import ColourInput, Texture
    from cp_stylize.settings import StylizeSettings

    mesh, band, _, _ = sphere
    _, faces, uvs = parametric_mesh(Sphere().point, 96, 48, periodic_u=True)
    picture = ColourInput(textures=[Texture(np.zeros((4, 4, 3), np.float32), uvs, np.ones(len(faces), bool))])

    def share(swirl, colours=picture):
        level = stroke_level(mesh, band, StylizeSettings(mode="gaussian", swirl=swirl), field=None, colours=colours)
        return None if level is None else np.linalg.norm(level, axis=1)

    assert share(0.6) is None                                      # swirls, or each dab its own way: no combing
    calm, half = share(0.0), share(0.25)
    assert np.median(calm) > 0.99 and abs(np.median(half) - 0.5) < 0.01   # a brush that never swirls: all level
    assert share(0.0, ColourInput.constant(mesh.n_input_faces, (0.5, 0.5, 0.5))) is None   # no picture


def test_a_guide_counts_only_where_it_agrees_with_itself_over_a_strokes_length(sphere):
    from cp_stylize.stroke_field import agreement

    mesh, band, _, _ = sphere
    n = band.cp / np.linalg.norm(band.cp, axis=1, keepdims=True)
    length = 0.3
    # the parallels ring the pole in ever smaller circles: no direction there over a stroke's length
    parallels = np.cross([0.0, 0.0, 1.0], n)
    agree = agreement(band, parallels, length)
    from_pole = np.arccos(np.clip(np.abs(n[:, 2]), 0.0, 1.0))               # on the unit sphere: the distance
    assert np.all(agree[from_pole < 0.5 * length] == 0.0)
    assert np.min(agree[from_pole > 0.4 * np.pi]) > 0.95                     # about the equator: one direction
    # a chevron: a picture's horizontal mirrored at x = 0 (Suzanne's two halves), at 45 degrees to the mirror
    chevron = np.column_stack([np.ones(band.size), np.zeros(band.size), np.sign(band.cp[:, 0])])
    agree = agreement(band, chevron, length)
    side = np.abs(n[:, 1]) > 0.9                                              # where the fold runs up the surface
    assert np.all(agree[side & (np.abs(band.cp[:, 0]) < 0.05)] < 0.05)      # folded: not followed
    assert np.min(agree[side & (np.abs(band.cp[:, 0]) > 0.35)]) > 0.9       # a stroke's length off: followed
    # no direction anywhere: nothing to follow
    assert not agreement(band, np.zeros((band.size, 3)), length).any()


def test_strokes_do_not_ring_a_pole_that_the_level_rings(sphere):
    from cp_stylize.painting import painting
    from cp_stylize.stroke_field import level_field

    mesh, band, atlas, _ = sphere
    centres = np.asarray(mesh.vertices)[np.asarray(mesh.input_faces)].mean(axis=1)
    level = level_field(band, None, np.cross([0.0, 0.0, 1.0], centres))   # the picture's horizontal: the parallels
    grey = np.full((band.size, 3), 0.4, dtype=np.float32)                  # no structure anywhere
    brush = Brush(width=0.06, length=0.24, layers=1, chain=1, seed=3)
    dabs = painting(mesh, band, grey, atlas, brush=brush, level=level).dabs
    unit = dabs.centre / np.linalg.norm(dabs.centre, axis=1, keepdims=True)
    parallels = np.cross([0.0, 0.0, 1.0], unit)
    parallels /= np.maximum(np.linalg.norm(parallels, axis=1, keepdims=True), 1e-12)
    along = np.abs(np.einsum("ij,ij->i", dabs.direction, parallels))
    from_pole = np.arccos(np.clip(np.abs(unit[:, 2]), 0.0, 1.0))
    assert np.median(along[from_pole > 0.4 * np.pi]) > 0.95          # level strokes about the equator
    pole = from_pole < 0.15                                          # within about half a stroke of the pole
    assert pole.sum() >= 20 and np.median(along[pole]) < 0.8         # no bullseye (0.99 if they followed it)


def test_a_dab_that_its_uv_raster_would_cut_off_is_drawn_whole(sphere, monkeypatch):
    mesh, band, atlas, texels = sphere
    # near a UV sphere's poles the map stretches fast: a dab's raster, sized by the map at its centre, is too
    # small on one side of it; a dab cut off there would stand in the relief with a straight step (a crack)
    brush = Brush(width=0.12, length=0.45, layers=1, seed=2)
    grey = np.full((band.size, 3), 0.5, dtype=np.float32)
    dabs = place_dabs(mesh, band, grey, brush, texel=0.01)
    base = np.zeros((len(texels.points), 3))
    reference = np.full((len(texels.points), 3), 0.5)
    drawn, height = paint(dabs, texels, base, reference)
    monkeypatch.setattr(canvas, "WHOLE", 2.0)                  # every dab from the search in space
    searched, searched_height = paint(dabs, texels, base, reference)
    inside = np.arange(len(texels.points)) < texels.covered
    assert np.abs(searched_height[inside]).max() > 0.1
    np.testing.assert_allclose(height[inside], searched_height[inside], atol=1e-3)     # (1.17 off where cut)
    np.testing.assert_allclose(drawn[inside], searched[inside], atol=1e-3)


def test_a_dab_that_runs_a_little_way_over_a_uv_seam_is_drawn_on_both_sides(sphere, monkeypatch):
    mesh, band, atlas, texels = sphere
    # the UV sphere's seam runs along y = 0, x < 0 (u = 0 meets u = 1 at the atlas's two edges); a dab along
    # the equator that reaches over it by a few per cent of its area must go on over it, or its relief
    # stands with a step along the seam (a crack)
    phi = np.pi - 0.36                                               # its tail's tip 0.04 over the seam
    dab = _one_dab(mesh, [np.cos(phi), np.sin(phi), 0.0], [-np.sin(phi), np.cos(phi), 0.0], length=0.8, width=0.2)
    dab.ends = np.zeros(1, np.int8)                                  # within its stroke: paint to its tip
    base = np.zeros((len(texels.points), 3))
    reference = np.tile(dab.colour, (len(base), 1))
    _, height = paint(dab, texels, base, reference)
    monkeypatch.setattr(canvas, "WHOLE", 2.0)                  # drawn from the search in space
    _, searched = paint(dab, texels, base, reference)
    inside = np.arange(len(texels.points)) < texels.covered
    over = inside & (texels.points[:, 1] < 0) & (texels.points[:, 0] < -0.9)     # across the seam
    assert np.any(searched[over] > 0.05)
    np.testing.assert_allclose(height[inside], searched[inside], atol=1e-3)


def test_a_broad_dab_over_a_sharp_bend_fades_out_instead_of_stopping_in_a_step(sphere):
    mesh, band, atlas, texels = sphere
    # a dab as long as half the sphere: where the surface turns away from it, its paint thins out over the
    # turn; a cut at one angle stood in its relief as a step along the mesh's edges (a crack under a light)
    dab = _one_dab(mesh, [0.0, -1.0, 0.0], [0, 0, 1], length=3.0, width=0.3)
    dab.ends = np.zeros(1, np.int8)
    base = np.zeros((len(texels.points), 3))
    _, height = paint(dab, texels, base, np.tile(dab.colour, (len(base), 1)))
    p = texels.points
    line = np.flatnonzero((p[:, 1] < 0) & (np.abs(p[:, 0]) < 0.01) & (p[:, 2] > 0))   # up its centre line
    line = line[np.argsort(p[line, 2])]
    profile = height[line]
    assert profile.max() > 0.3 and profile[-1] == 0.0               # it ends before the sphere's pole
    turned = np.einsum("ij,ij->i", texels.normals[line], dab.normal)
    assert np.all(profile[turned < canvas.FACING[0]] == 0.0)        # none on the surface turned away
    assert np.max(np.abs(np.diff(profile))) < 0.15 * profile.max()  # and no step on the way


def test_no_dabs_pick_up_no_colour_without_an_error(sphere):
    from cp_stylize.strokes import _picked_up

    mesh, band, _, _ = sphere
    colours = _stripes(band, [0, 0, 1])
    none = np.zeros((0, 3))
    picked = _picked_up(band, colours, none, none, np.zeros(0, np.int64), none, np.zeros(0))
    assert picked.shape == (0, colours.shape[1])


def test_a_line_up_to_the_finest_dabs_width_is_laid_as_a_line_not_left_to_the_dabs(sphere):
    texels = sphere[3]
    half = 0.042
    plain, _ = _equator_line(sphere, half)
    lined, _ = _equator_line(sphere, half, detail=0.4, fine=0.1)
    on, away = np.abs(texels.points[:, 2]) < 0.5 * half, texels.points[:, 1] > -0.5
    # a branch 0.084 wide, under the finest dabs' 0.1, is a line as a hairline is (the test above): a bare
    # branch against the sky is drawn, not smudged by dabs too broad to hold it
    assert (on & away).sum() > 50 and (plain - lined)[on & away].mean() > 0.15


def test_the_relief_has_no_cliff_steeper_than_its_slope_and_is_lowered_only_at_cliffs():
    """A dab's edge over thick paint, a texel-wide cliff, becomes a ramp no steeper than the step allowed (the
    Bump node would shade a cliff as a black hairline); gentle paint keeps its height, and texels off the
    atlas's charts bind nothing, and one chart's paint binds no other's across them."""
    from cp_stylize.painting import slope_limited

    size, step = 96, 0.1
    v, u = np.mgrid[0:size, 0:size]
    gentle = 0.02 * u + 0.3 * np.sin(v / 9.0)                     # steps of at most 0.035 a texel
    height = gentle + np.where((u > 20) & (u < 70) & (v > 20) & (v < 70), 1.0, 0.0)    # a block of thick paint
    covered = ~((u < 6) & (v < 6))                                # a corner off the charts
    flat = np.flatnonzero(covered.ravel())
    limited = np.full(size * size, np.nan)
    limited[flat] = slope_limited(height.ravel()[flat].astype(np.float32), flat, size, step)
    limited = limited.reshape(size, size)
    assert np.all(limited[covered] <= height[covered] + 1e-6)               # never raised
    for axis in (0, 1):
        steps = np.abs(np.diff(limited, axis=axis))
        assert np.nanmax(steps) <= step + 1e-5                    # no cliff along either axis
    assert np.abs(np.diff(height, axis=1)).max() > 0.9            # (there was one)
    far = (np.abs(u - 45) > 36) | (np.abs(v - 45) > 36)           # away from the block the paint is as it was
    np.testing.assert_allclose(limited[far & covered], height[far & covered], atol=1e-5)
    # the block's middle keeps its thickness: the ramp is about ten texels long
    assert limited[45, 45] == pytest.approx(height[45, 45], abs=1e-5)
    assert np.isfinite(limited[covered]).all()
    # a chart's paint is not pulled down by another chart's across the gutter between them
    gutter = np.ones((8, 8), bool)
    gutter[:, 3:5] = False
    two = np.where(np.arange(8) < 4, 0.0, 1.0)[None, :].repeat(8, axis=0)
    flat = np.flatnonzero(gutter.ravel())
    np.testing.assert_array_equal(slope_limited(two.ravel()[flat].astype(np.float32), flat, 8, step),
                                  two.ravel()[flat])


def test_keep_darks_keys_the_paints_light_and_dark_to_the_pictures_and_keeps_each_strokes_own():
    """Paint lifted over the picture's darks (smoothing and strokes spread the lights' paint over them) comes
    down to the picture's darks at the scale of a broad stroke, while each stroke's own light and shade about
    it stays; over the picture's lights the paint keys to the mapped picture's lightness alone."""
    from cp_stylize.oklab import from_oklab, to_oklab
    from cp_stylize.painting import KEY_DARK, KEY_REACH, _blurred, _keyed

    size, width = 160, 10.0                                                # broad dabs ten texels wide
    sigma = KEY_REACH * width
    v, u = np.mgrid[0:size, 0:size]
    own = np.where(u < size // 2, 0.15, 0.75).ravel()                     # a dark half and a light half
    mapped = np.where(u < size // 2, 0.32, 0.8).ravel()                   # the palette lifted the darks
    strokes = 0.06 * np.sign(np.sin(np.pi * (u + 0.4 * v) / width)).ravel()   # each dab lighter or darker
    lifted = mapped + 0.08 + strokes                                       # and the painting lifted them more
    lab = np.column_stack([lifted, np.full(size * size, 0.03), np.full(size * size, 0.05)])
    painted = from_oklab(lab)
    flat = np.flatnonzero(np.ones(size * size, bool))
    keyed = to_oklab(_keyed(painted, mapped, own, flat, size, sigma, 1.0))[:, 0]
    smooth = _blurred(keyed, flat, size, sigma)
    inner = (np.abs(u - size // 2) > 4 * sigma).ravel() & (np.minimum(u, size - 1 - u) > 4 * sigma).ravel()
    dark, light = inner & (own < KEY_DARK[0]), inner & (own > KEY_DARK[1])
    assert np.abs(smooth[dark] - 0.2).max() < 0.01          # down to the picture's darks (not below the floor, 0.2)
    assert np.abs(smooth[light] - 0.8).max() < 0.01         # the lights at the mapped picture's lightness
    kept, before = keyed - smooth, lifted - _blurred(lifted, flat, size, sigma)    # each dab against the paint about it
    assert np.corrcoef(kept[inner], strokes[inner])[0, 1] > 0.95     # each stroke's light and shade kept ...
    assert np.std(kept[inner]) == pytest.approx(np.std(before[inner]), rel=0.15)     # ... at its strength
    np.testing.assert_allclose(_keyed(painted, mapped, own, flat, size, sigma, 0.0), painted, atol=1e-6)


def test_a_broad_blur_of_the_atlas_on_a_coarser_grid_is_the_gaussians_over_the_charts():
    """The blur Keep Darks keys with, taken on a grid coarser by a whole factor when it is broad, is the Gaussian
    of the texels on the charts (the texels off them counting for nothing) within a few hundredths of its range."""
    from scipy import ndimage

    from cp_stylize.painting import BLUR_CELLS, _blurred

    size, sigma = 256, 12.0
    v, u = np.mgrid[0:size, 0:size]
    charts = ((u - 80) ** 2 + (v - 120) ** 2 < 70**2) | ((u > 170) & (u < 240) & (v > 20) & (v < 230))
    flat = np.flatnonzero(charts.ravel())
    rng = np.random.default_rng(4)
    values = (np.where(u < 100, 0.2, 0.8) + 0.1 * rng.standard_normal((size, size))).ravel()[flat]
    image, weight = np.zeros(size * size), np.zeros(size * size)
    image[flat], weight[flat] = values, 1.0
    exact = (ndimage.gaussian_filter(image.reshape(size, size), sigma, mode="constant")
             / np.maximum(ndimage.gaussian_filter(weight.reshape(size, size), sigma, mode="constant"),
                          1e-12)).ravel()[flat]
    assert int(sigma / BLUR_CELLS) > 1                              # (the coarse grid is what is tested)
    blurred = _blurred(values, flat, size, sigma)
    assert np.quantile(np.abs(blurred - exact), 0.99) < 0.02 and np.abs(blurred - exact).max() < 0.05
    np.testing.assert_allclose(_blurred(values, flat, size, 2.0),       # a narrow one is taken as it is
                               (ndimage.gaussian_filter(image.reshape(size, size), 2.0, mode="constant")
                                / np.maximum(ndimage.gaussian_filter(weight.reshape(size, size), 2.0,
                                                                     mode="constant"), 1e-12)).ravel()[flat],
                               atol=1e-9)
