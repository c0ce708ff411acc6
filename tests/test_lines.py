"""Ink lines at the texels: the flow-based difference of Gaussians (Kang, Lee and Chui, 2007) on the surface."""

import numpy as np
import pytest

from cp_stylize.atlas import uv_atlas
from cp_stylize.baking import atlas_points, texel_lengths
from cp_stylize.lines import Lines, flow_dog
from cp_stylize.mesh import TriangleMesh, parametric_mesh
from cp_stylize.pipeline import ColourInput, stylize
from cp_stylize.presets import StylizeSettings
from cp_stylize.sampling import Texture, colours_at
from cp_stylize.surfaces import Torus


def _frames(size, across=(0.0, 1.0), along=(1.0, 0.0)):
    return (np.broadcast_to(np.asarray(across, float), (size, size, 2)),
            np.broadcast_to(np.asarray(along, float), (size, size, 2)))


def test_a_thin_dark_line_answers_negative_and_flat_colour_positive():
    size = 64
    image = np.ones((size, size))
    image[:, 31:33] = 0.2                                  # a dark line two texels wide, down the columns
    rows, cols = np.mgrid[0:size, 0:size]
    position = np.column_stack([rows.ravel(), cols.ravel()]).astype(float)
    response = flow_dog(image, position, *_frames(size), np.ones(size * size)).reshape(size, size)
    assert (response[8:-8, 31:33] < -0.05).all()           # on the line
    assert (response[8:-8, :20] > 0).all() and (response[8:-8, 44:] > 0).all()   # flat colour: no ink
    # across the wrong way (along the line), the line is not seen
    wrong = flow_dog(image, position, *_frames(size, (1.0, 0.0), (0.0, 1.0)), np.ones(size * size))
    assert wrong.reshape(size, size)[8:-8, 31:33].min() > -0.01


def test_a_step_edge_is_inked_on_its_dark_side_only():
    size = 64
    image = np.where(np.arange(size)[None, :] < 32, 0.3, 0.9) * np.ones((size, 1))
    rows, cols = np.mgrid[0:size, 0:size]
    position = np.column_stack([rows.ravel(), cols.ravel()]).astype(float)
    response = flow_dog(image, position, *_frames(size), np.ones(size * size)).reshape(size, size)
    assert response[32, 29:32].min() < -0.05               # the dark side, next to the edge
    assert response[32, 32:40].min() > -0.01               # the light side


def _plane(width=2.0, cells=32):
    """A ``width`` x 1 rectangle in the plane z = 0, its UVs the unit square (so its texels are ``width``
    times longer across than down)."""
    return parametric_mesh(lambda s, t: np.stack([width * s, t, 0 * s], axis=-1), cells, cells)


def _ink(vertices, faces, uvs, image, size, width=0.02):
    mesh = TriangleMesh(vertices, faces)
    atlas = uv_atlas(mesh, size, uvs)
    texels = atlas_points(mesh, atlas, 8)
    colours = ColourInput(textures=[Texture(image, uvs, np.ones(len(faces), bool))])
    lines = Lines(mesh, atlas, width, detail=0.5, source=lambda f, b: colours_at(f, b, colours))
    amount = np.zeros(size * size)
    amount[texels[0]] = lines.amount(texels, np.zeros((len(texels[0]), 3)))
    return amount.reshape(size, size), texel_lengths(mesh, atlas, atlas.face)


def test_lines_are_as_wide_on_the_surface_whichever_way_the_texels_are_stretched():
    """On a 2 x 1 rectangle mapped to a square image, a texel is twice as long across as down: a line
    of a given width on the surface is half as many texels wide across as down."""
    vertices, faces, uvs = _plane()
    size = 256
    image = np.ones((size, size, 3), np.float32)
    image[:, 100:102] = 0.1                                # a dark line 2 texels (0.0156) wide, down the image
    image[150:154, :] = 0.1                                # and one 4 texels (0.0156) high, across it
    ink, _ = _ink(vertices, faces, uvs, image, size)
    across_line = (ink[30:90, :] > 0.5).sum(axis=1).mean() * 2.0 / size     # on the surface
    down_line = (ink[:, 160:240] > 0.5).sum(axis=0).mean() * 1.0 / size
    assert across_line > 0 and down_line > 0
    assert 0.7 < across_line / down_line < 1.4


def test_a_line_runs_on_across_a_uv_seam():
    """A dark line around a torus, across the seam where its UVs wrap: the ink on both sides of the seam
    is alike."""
    vertices, faces, uvs = parametric_mesh(Torus(10.0, 4.0).point, 64, 32, periodic_u=True, periodic_v=True)
    size = 256
    image = np.ones((size, size, 3), np.float32)
    image[126:130, :] = 0.1                                # a line along u, across the seam at u = 0 = 1
    ink, _ = _ink(vertices, faces, uvs, image, size, width=0.05)
    near_seam = np.concatenate([ink[110:146, :6], ink[110:146, -6:]], axis=1)
    inside = ink[110:146, 100:112]
    assert inside.max() > 0.9
    assert np.abs(near_seam.sum(axis=0).mean() - inside.sum(axis=0).mean()) < 0.15 * inside.sum(axis=0).mean()


def test_a_flat_picture_gets_no_ink():
    vertices, faces, uvs = _plane()
    image = np.full((64, 64, 3), 0.4, np.float32)
    ink, _ = _ink(vertices, faces, uvs, image, 64)
    assert ink.max() == 0.0


def test_a_run_with_lines_darkens_the_picture_along_its_edges_only():
    vertices, faces, uvs = _plane()
    image = np.ones((64, 64, 3), np.float32)
    image[:, 32:] = (0.2, 0.3, 0.8)                        # white beside blue: one edge down the middle
    colours = ColourInput(textures=[Texture(image, uvs, np.ones(len(faces), bool))])
    settings = StylizeSettings(mode="gaussian", T=1e-6, spacing=0.03, image_size=64, margin=4, line_width=0.02)
    inked = stylize(vertices, faces, colours, settings, uvs=uvs).image
    plain = stylize(vertices, faces, colours, settings.replace(line_width=0.0), uvs=uvs).image
    darker = plain.sum(axis=2) - inked.sum(axis=2)
    assert darker[8:-8, 30:36].max() > 0.3                 # the edge is inked
    assert np.abs(darker[:, :24]).max() < 1e-6 and np.abs(darker[:, 44:]).max() < 1e-6   # flat colour is not


def test_lines_are_checked_as_settings():
    with pytest.raises(ValueError, match="line_width"):
        StylizeSettings(mode="gaussian", line_width=-0.01)
    with pytest.raises(ValueError, match="line_detail"):
        StylizeSettings(mode="gaussian", line_detail=1.5)


def test_specks_of_ink_are_dropped_and_lines_kept():
    from cp_stylize.lines import SPECK, _without_specks

    size = 1024
    ink = np.zeros((size, size))
    ink[100:102, 100:300] = 1.0                            # a line
    ink[500:503, 500:503] = 1.0                            # a speck of 9 texels
    ink[499, 499:504] = 0.2                                # and its faint rim
    out = _without_specks(ink.ravel(), np.arange(size * size), size).reshape(size, size)
    assert SPECK > 9
    assert np.array_equal(out[90:110, 90:310], ink[90:110, 90:310])
    assert out[490:510, 490:510].max() == 0.0
