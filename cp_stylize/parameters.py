"""The parameters of a stylization run, and each filter mode's: one table.

Every number a user can set is a :class:`Parameter` here, with its label,
description, limits, unit and (for the run's own) its key in a preset file.  :data:`FILTERS` says which filter parameters
each mode takes and their defaults.  The core's validation
(:class:`~cp_stylize.settings.StylizeSettings`, so preset files too), the
add-on's properties and panel, and the user guide's tables (docs/blender.md) are all built from
these, so a new parameter or mode is an edit in this file.

Units are those of an object normalised to a diameter of 2 (the greatest
distance between two points of its surface: a sphere of radius 1; paper,
section 4.5): ``"time"`` is a diffusion time in squared lengths, ``"length"``
a length, ``"ratio"`` a number relative to the input's own contrast or a
fraction, ``"count"`` a whole number.

An artist reads lengths and times as sizes on the object: :meth:`Parameter.size`
gives each as a length (a time ``t`` as the radius ``sqrt(2 t)`` of the Gaussian
blur it matches), which the add-on shows in the scene's units for the object
at hand, under :attr:`Parameter.size_label`.
"""

from __future__ import annotations

import dataclasses
import math

__all__ = ["Parameter", "Filter", "RUN", "FILTER_PARAMETERS", "FILTERS", "MODES", "DEFAULTS", "DIRECTIONS",
           "DIRECTED_MODES", "AXIS_DIRECTIONS", "CURVATURE_DIRECTIONS", "NOISE_MAPPINGS", "SEED_LIMITS",
           "IMAGE_SIZE_CHOICES", "check_value", "takes_direction", "paints_shading"]


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One number a user sets: its name (keyword and preset key), label, limits and unit."""

    name: str
    label: str
    description: str
    minimum: float
    maximum: float
    default: float
    unit: str = "ratio"      # "time", "length", "ratio" or "count" (a whole number)
    precision: int = None    # decimals the panel shows: by default 2 for a ratio (a share or strength), else 5;
    #                          Blender shows up to three significant digits of a value below 10^-precision
    step: float = 0.001      # the panel's drag step (Blender's units of 1/100)
    file: tuple = (None, None)   # a run parameter's place in a preset file: (table or None for the top, key)
    size_name: str = ""      # a time's label as a size (the blur's radius), where it differs from ``label``

    def __post_init__(self):
        if self.precision is None:
            object.__setattr__(self, "precision", 2 if self.unit == "ratio" else 5)

    @property
    def sized(self):
        """Whether the parameter is shown as a size: a length, or a time (as its blur's radius)."""
        return self.unit in ("length", "time")

    @property
    def size_label(self):
        return self.size_name or self.label

    def size(self, value):
        """``value`` as a length (object normalised to a diameter of 2): a length as it is, a time ``t`` as the
        radius ``sqrt(2 t)`` of the Gaussian blur it matches."""
        return math.sqrt(2.0 * max(value, 0.0)) if self.unit == "time" else value

    def from_size(self, size):
        """The value whose :meth:`size` is ``size``, within the limits."""
        value = 0.5 * max(size, 0.0) ** 2 if self.unit == "time" else size
        return min(max(value, self.minimum), self.maximum)

    def check(self, value):
        """``value`` as a float (an int for a count), or ValueError naming the parameter, its limits and the
        value."""
        checked = check_value(self.name, value, self.minimum, self.maximum)
        if self.unit == "count":
            if checked != int(checked):
                raise ValueError(f"{self.name} must be a whole number in [{self.minimum:g}, {self.maximum:g}], "
                                 f"got {value!r}")
            return int(checked)
        return checked


#: Relative slack of the limits: Blender stores the panel's values in single precision.
_SLACK = 1e-6


def check_value(name, value, minimum, maximum):
    """``float(value)`` if it is a real number in ``[minimum, maximum]``, else ValueError."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or not minimum - _SLACK * abs(minimum) <= value <= maximum + _SLACK * abs(maximum):
        raise ValueError(f"{name} must lie in [{minimum:g}, {maximum:g}], got {value!r}")
    return float(value)


#: The run's own parameters.
RUN = {p.name: p for p in (
    Parameter("T", "Time", "Diffusion time T (squared lengths of the object normalised to a diameter of 2): how far the "
                           "filter goes. The blur radius grows like sqrt(2 T)", 1e-6, 0.1, 1.1e-4, "time",
              file=(None, "T"), size_name="Smoothing"),
    Parameter("spacing", "Grid Spacing", "Grid spacing h of the band for the object normalised to a "
                                         "diameter of 2", 0.002, 0.1, 0.008, "length", precision=4, step=0.1,
              file=(None, "spacing")),
    Parameter("noise_fraction", "Noise", "Share of the band points replaced by palette colours before the "
                                         "filter (painterly looks; 0 for none)", 0.0, 1.0, 0.0,
              file=("noise", "fraction")),
    Parameter("noise_spread", "Spread", "Noise by tone and hue: how far from its own colour a point may pick "
                                        "its palette colour (0: the nearest; 1: any)", 0.0, 1.0, 0.1,
              file=("noise", "spread")),
    Parameter("detail", "Detail", "How much of the texture's own detail, finer than the grid, comes back over "
                                  "the result where the filter leaves it (1: a run that changes nothing gives "
                                  "back the texture; 0: the grid's resolution); under brush strokes, its "
                                  "lightness shows in the paint (windows, lettering) and its thin dark lines (a "
                                  "mast, bare branches; below 0.4 only the long ones) are drawn over the strokes",
              0.0, 1.0, 1.0,
              file=(None, "detail")),
    Parameter("strokes", "Strokes", "Brush strokes: dabs of paint laid on the surface in layers, coarse to fine, "
                                    "along the picture's edges, this opaque (0: none)", 0.0, 1.0, 0.0,
              file=("strokes", "strength")),
    Parameter("stroke_length", "Stroke Length", "Length of the largest dabs of paint (object normalised to a "
                                                "diameter of 2); the first layer lays up to Chain of them end to "
                                                "end along the picture, as one long stroke", 0.01, 1.0, 0.1, "length",
              precision=3, step=1, file=("strokes", "length")),
    Parameter("stroke_width", "Stroke Width", "Width of the largest brush strokes (object normalised to a diameter "
                                              "of 2); strokes narrower than three texels are not drawn",
              0.003, 0.2, 0.03, "length", precision=4, step=0.1,
              file=("strokes", "width")),
    Parameter("stroke_layers", "Layers", "Layers of strokes, coarse to fine: each layer's strokes are 1.45 times "
                                         "narrower and go only where the picture has detail", 1, 4, 3, "count",
              precision=0, step=100,
              file=("strokes", "layers")),
    Parameter("stroke_chain", "Chain", "Dabs the first layer lays end to end along the picture as one stroke, "
                                       "while the picture's colour under it stays alike; the second layer takes "
                                       "half as many, the third a third (1: single dabs)", 1, 8, 3,
              "count", precision=0, step=100,
              file=("strokes", "chain")),
    Parameter("broad_paint", "Broad Paint", "Where the finer layers' strokes go: 0 wherever the picture has "
                                            "structure (its texture in fine strokes); 1 only where the broad "
                                            "strokes missed the picture (an edge or a feature they stopped at or "
                                            "crossed), so a fine texture stays in broad paint", 0.0, 1.0, 0.0,
              file=("strokes", "broad")),
    Parameter("stroke_jitter", "Jitter", "How far each stroke's colour moves towards a neighbouring palette colour "
                                         "(broken colour; 0: the picture's colour under the stroke)", 0.0, 1.0, 0.3,
              file=("strokes", "jitter")),
    Parameter("swirl", "Swirl", "Where the picture has little structure, strokes circle in swirls this much "
                                "where it is light, as in a sky (0: they run level with the picture's horizon there; "
                                "from 0.5 none run level)",
              0.0, 1.0, 0.0,
              file=("strokes", "swirl")),
    Parameter("stars", "Stars", "Up to this many stars at the picture's lights (its calm parts that stand out lightest), as in van "
                                "Gogh's \"The Starry Night\" (1889): a bright core ringed by halos of strokes that "
                                "circle it (0: none; with strokes)", 0, 40, 0, "count", precision=0, step=100,
              file=("strokes", "stars")),
    Parameter("fidelity", "Fidelity", "How much of the picture's own colours the palette keeps: 0 the palette "
                                      "alone, 0.5 the picture's hues in the palette's tones, 1 the picture's colours",
              0.0, 1.0, 0.0,
              file=("noise", "fidelity")),
    Parameter("keep_values", "Keep Values", "How much of the picture's own light and dark the palette keeps: "
                                            "0 spreads the picture's tones over the palette's (each colour takes "
                                            "its weight's share), 1 keeps the picture's lightness and lets the "
                                            "palette choose hue and chroma", 0.0, 1.0, 0.0,
              file=("noise", "keep_values")),
    Parameter("keep_darks", "Keep Darks", "How much more of the picture's own light and dark the palette keeps in "
                                          "its darks than in its lights: the share kept rises from Keep Values "
                                          "towards 1 in the darkest tones (0: as much in every tone; a forest's "
                                          "shade stays dark while its lights take the palette's light colours); "
                                          "with strokes, the paint's light and dark over a broad stroke's width "
                                          "keeps as much to the picture's, each stroke keeping its own light and "
                                          "shade",
              0.0, 1.0, 0.0,
              file=("noise", "keep_darks")),
    Parameter("hue_snap", "Palette Hues", "How far the hues Fidelity brings back turn to the palette's nearest "
                                          "hues: 0 the picture's own hues, 1 the palette's (a grey-blue sky takes "
                                          "the palette's blue-green, not a lilac the palette lacks; at Fidelity 1, "
                                          "the picture's lightness and chroma in the palette's hues)", 0.0, 1.0, 0.0,
              file=("noise", "hue_snap")),
    Parameter("contours", "Contours", "Dark lines along the picture's strong edges, drawn on the surface, this "
                                      "strong (0: none)", 0.0, 1.0, 0.0,
              file=(None, "contours")),
    Parameter("oil_size", "Oil Paint", "Oil paint: the size of the neighbourhood each point takes its colour from "
                                       "(object normalised to a diameter of 2; at least two grid spacings), "
                                       "Kyprianidis, Kang and Döllner's anisotropic Kuwahara filter on the surface: "
                                       "regions of like colour flatten, their edges stay; Detail does not come back "
                                       "over it (0: none)",
              0.0, 0.2, 0.0, "length", precision=4, step=0.1, file=("oil", "size")),
    Parameter("oil_sharpness", "Sharpness", "Oil paint: how sharply a region's edge divides its colours (0: the "
                                            "neighbourhood's sectors averaged, smooth; 1: the most alike sector "
                                            "alone, sharp)", 0.0, 1.0, 0.5, precision=2,
              file=("oil", "sharpness")),
    Parameter("oil_eccentricity", "Eccentricity", "Oil paint: how far the neighbourhood stretches along the "
                                                  "picture's edges and strokes (0: round everywhere; 2: long "
                                                  "and thin along a clear direction)", 0.0, 2.0, 1.0,
              precision=2, step=1, file=("oil", "eccentricity")),
    Parameter("toon_levels", "Toon Levels", "Toon shading: the picture's lightness in this many flat bands, hue "
                                            "and chroma its own (Winnemöller, Olsen and Gooch's quantisation; "
                                            "0: none)", 0, 8, 0, "count", precision=0, step=100,
              file=("toon", "levels")),
    Parameter("toon_softness", "Softness", "Toon shading: how gently one band of lightness steps to the next (0: a "
                                           "hard step; 1: a gentle ramp)", 0.0, 1.0, 0.3, precision=2,
              file=("toon", "softness")),
    Parameter("toon_outlines", "Outlines", "Toon shading: black lines a texel wide along the borders between the "
                                           "bands, on their dark side, this strong (0: none)", 0.0, 1.0, 0.0,
              precision=2,
              file=("toon", "outlines")),
    Parameter("wash_levels", "Washes", "Watercolour: the picture's lightness in this many washes of transparent "
                                       "pigment on paper, hue and chroma its own, each darker at its border "
                                       "(Curtis et al., \"Computer-generated watercolor\", 1997; Bousseau et al., "
                                       "\"Interactive watercolor rendering with temporal coherence and "
                                       "abstraction\", 2006; 0: none)", 0, 8, 0, "count", precision=0, step=100,
              file=("watercolour", "washes")),
    Parameter("wash_edges", "Edge Darkening", "Watercolour: how much pigment pools inside a darker wash along its "
                                              "border with a lighter one, where it dried (0: none)", 0.0, 1.0, 0.5, precision=2,
              file=("watercolour", "edges")),
    Parameter("wash_granulation", "Granulation", "Watercolour: how much the pigment settles in the paper's grain, "
                                                 "most in the dark washes (0: smooth washes on smooth paper)",
              0.0, 1.0, 0.5, precision=2, file=("watercolour", "granulation")),
    Parameter("wash_bleed", "Bleeding", "Watercolour: the share of the washes' borders where one ran wet into the "
                                        "next, soft and without a dark rim (0: every border dried hard)",
              0.0, 1.0, 0.3, precision=2, file=("watercolour", "bleed")),
    Parameter("wash_wobble", "Wobble", "Watercolour: how far the washes' borders meander where the picture's "
                                       "lightness changes slowly (0: they follow it exactly)", 0.0, 1.0, 0.5,
              precision=2, file=("watercolour", "wobble")),
    Parameter("line_width", "Lines", "Ink lines along the picture's edges and thin dark lines, this wide (object "
                                     "normalised to a diameter of 2; at least a texel and a half), by Kang, Lee and "
                                     "Chui's flow-based difference of Gaussians on the surface, as sharp as the "
                                     "texels (0: none)",
              0.0, 0.05, 0.0, "length", precision=4, step=0.1, file=("lines", "width")),
    Parameter("line_detail", "Line Detail", "Ink lines: how many of the picture's edges get a line (0: the "
                                            "strongest alone; 1: most of them, fainter ones too)", 0.0, 1.0, 0.5,
              precision=2,
              file=("lines", "detail")),
    Parameter("hatch_spacing", "Hatching", "Ink hatching: the picture in lines of ink on white paper, this far "
                                           "apart (object normalised to a diameter of 2), along the picture's "
                                           "structure or the form; the darker the tone, the wider the lines and "
                                           "the more layers cross them (0: none)",
              0.0, 0.1, 0.0, "length", precision=4, step=0.1, file=("hatching", "spacing")),
    Parameter("hatch_layers", "Layers", "Ink hatching: how many layers of lines the darkest tones take, each "
                                        "crossing the one before (1 to 3)", 1, 3, 3, "count", precision=0, step=100,
              file=("hatching", "layers")),
    Parameter("hatch_angle", "Cross Angle", "Ink hatching: the angle in degrees between the first layer of lines "
                                            "and the second (the third lies halfway between)", 15, 90, 90, "count", precision=0, step=100,
              file=("hatching", "angle")),
    Parameter("hatch_ink", "Ink", "Ink hatching: how much ink the picture's tones take (0.5: its own values, its "
                                  "lightest clean paper and its darkest near-solid ink; towards 0 lighter, towards "
                                  "1 darker)", 0.0, 1.0, 0.5,
              precision=2, file=("hatching", "ink")),
    Parameter("hatch_swell", "Swell", "Ink hatching: how wide the last layer's lines swell in the darkest tones, "
                                      "as a share of their spacing (0.55: paper stays between the lines; 0.85: only "
                                      "thin white cuts, as in a woodcut; 1: solid ink)", 0.35, 1.0, 0.55,
              precision=2, file=("hatching", "swell")),
    Parameter("hatch_light", "Form Light", "Ink hatching: how much a light from the upper left front (fixed to "
                                           "the object, so it turns with it) shades the tones, so that the lines "
                                           "model the form even where the picture is one even tone (0: the "
                                           "picture's tones alone)", 0.0, 1.0, 0.0,
              precision=2, file=("hatching", "light")),
    Parameter("hatch_smooth", "Line Smoothing", "Ink hatching: how far the tone the lines' widths follow is "
                                                "smoothed along them, in spacings, so a line swells and thins "
                                                "smoothly instead of beading over fine detail (0: the picture's "
                                                "own tone, every edge kept)", 0.0, 1.0, 0.0,
              precision=2, file=("hatching", "smooth")),
    Parameter("relief", "Relief", "Height of the paint: the strokes' ridges and bristle grooves as a height "
                                  "image, wired through a Bump node, this strong (0: colour only)", 0.0, 1.0, 0.0,
              file=("strokes", "relief")),
    Parameter("sheen", "Sheen", "Light and shade of the paint's relief painted into its colour, under a light "
                                "from the object's upper left front (it turns with the object), so the strokes' "
                                "body reads in a flat view, an unlit material or a game engine (0: none)",
              0.0, 1.0, 0.0, file=("strokes", "sheen")),
    Parameter("shade_light", "Form Light", "Hand-painted shading: how much a light from above the object (a "
                                           "little to its left and front; it turns with the object) is painted "
                                           "into the colour, the side facing it lighter and the side turned away "
                                           "darker, so the form reads without a lamp (0: none)", 0.0, 1.0, 0.0,
              precision=2, file=("shading", "light")),
    Parameter("shade_edges", "Edges", "Hand-painted shading: how much the surface's own convex edges are "
                                      "lightened and its creases darkened, from its curvature (0: none)",
              0.0, 1.0, 0.0, precision=2, file=("shading", "edges")),
    Parameter("shade_warmth", "Warm and Cool", "Hand-painted shading: how much the hue moves with the painted "
                                               "light, lights towards a warm yellow and shadows towards a cool "
                                               "blue (0: lighter and darker only)", 0.0, 1.0, 0.0,
              precision=2, file=("shading", "warmth")),
)}

#: Seeds of the random noise: whole numbers a 32-bit integer holds, as Blender's integer properties do.
SEED_LIMITS = (0, 2**31 - 1)

#: The filter parameters any mode may take (see :func:`cp_stylize.diffuse`).
FILTER_PARAMETERS = {p.name: p for p in (
    Parameter("sigma", "Pre-smoothing", "Structure tensor pre-smoothing time sigma (the noise scale the "
                                        "filter ignores)", 0.0, 0.01, 1e-4, "time", size_name="Noise Size"),
    Parameter("rho", "Integration", "Structure tensor integration time rho (the size of the neighbourhood "
                                    "whose orientation the strokes follow)", 0.0, 0.05, 5e-4, "time", size_name="Flow Size"),
    Parameter("alpha", "Alpha", "CED: smallest diffusivity, across the flow. Flow: diffusivity along the "
                                "direction field (0 to 1)", 0.0, 1.0, 1e-3, precision=4, step=0.01),
    Parameter("b_rel", "Threshold", "CED's coherence threshold B, relative to the largest coherence of "
                                    "the input; smaller values draw strokes in weaker structure",
              0.0, 1.0, 1e-3, precision=5, step=0.0001),
    Parameter("beta", "Across", "Flow: largest diffusivity across the direction field, beta / (1 + "
                                "(|grad u_sigma| / lambda)^2)", 0.0, 1.0, 0.05, precision=4, step=0.01),
    Parameter("contrast", "Contrast", "Flow: how far values are pushed towards black or white over the run "
                                      "(e-folds of a mid-grey; 0 for none)", 0.0, 100.0, 0.0, precision=2, step=10),
    Parameter("ink", "Ink", "Flow: draw the flow texture of Diewald and Rumpf's noise as dark strokes over the texture, "
                            "which keeps its tones, this strong (0: the flow smooths the texture itself)",
              0.0, 1.0, 0.0, precision=2, step=10),
    Parameter("lambda_rel", "Edge Threshold", "Edge sensitivity lambda relative to the input's largest "
                                              "coherence (EED) or gradient (Perona-Malik, Beltrami, Flow)",
              1e-6, 10.0, 1e-3, precision=5, step=0.01),
)}


@dataclasses.dataclass(frozen=True)
class Filter:
    """A filter mode: its label, what it does, and its parameters with their defaults."""

    name: str
    label: str
    description: str
    defaults: dict

    @property
    def parameters(self):
        """The :class:`Parameter` of each filter parameter the mode takes, in table order."""
        return [FILTER_PARAMETERS[k] for k in FILTER_PARAMETERS if k in self.defaults]


#: The modes, in the order the panel lists them.  Defaults follow the paper:
#: EED and Perona-Malik its Fig. 4, CED its eq. (55).
FILTERS = {f.name: f for f in (
    Filter("ced", "Strokes (CED)",
           "Weickert's coherence-enhancing diffusion: smooths along the flow of the texture, painterly strokes",
           {"sigma": 1e-4, "rho": 4e-4, "alpha": 1e-3, "b_rel": 1e-3}),
    Filter("eed", "Denoise (EED)", "Weickert's edge-enhancing diffusion: removes noise, keeps edges sharp",
           {"sigma": 1.2e-4, "rho": 3.5e-4, "lambda_rel": 1e-3}),
    Filter("perona_malik", "Perona-Malik", "Edge-stopping smoothing",
           {"sigma": 1.2e-4, "lambda_rel": 1.0 / 13.0}),
    Filter("flow", "Flow (Form)", "Diewald and Rumpf's flow texture: smooths along a direction field on the surface "
                                  "(the principal curvature directions), sharpens across it",
           {"sigma": 1e-5, "alpha": 1.0, "beta": 0.05, "lambda_rel": 0.1, "contrast": 0.0, "ink": 0.0}),
    Filter("gaussian", "Gaussian Blur", "Uniform blur on the surface", {}),
    Filter("beltrami", "Beltrami", "Colour Beltrami flow: smooths regions, sharpens colour edges",
           {"sigma": 0.0, "lambda_rel": 0.1}),
)}

#: Where the strokes of CED and Flow take their direction from: name -> (label, description), in the
#: order the panel lists them.  CED follows the texture by default; Flow needs a field.
DIRECTIONS = {
    "texture": ("Texture", "The texture's own structure (CED's structure tensor); not for Flow"),
    "max": ("Max Curvature", "Across the form: the direction of the larger principal curvature"),
    "min": ("Min Curvature", "Along the form: the direction of the smaller principal curvature, around "
                             "a column, along a limb"),
    "axis": ("Axis", "A direction in the object's space, projected onto the surface (falls back to the "
                     "texture where the surface faces it)"),
    "around": ("Around Axis", "Around a direction in the object's space: its parallels on the surface, as "
                              "rings around a head or a column (falls back to the texture where the surface "
                              "faces it)"),
    "attribute": ("Attribute", "A vector attribute of the mesh (per point, corner or face)"),
}
#: The directions that read the settings' axis (in the object's space).
AXIS_DIRECTIONS = ("axis", "around")
#: The directions of the surface's own principal curvatures.
CURVATURE_DIRECTIONS = ("max", "min")
#: The image sizes the panel and the demo offer, in texels a side (a preset file may ask for any size within
#: :data:`cp_stylize.settings.IMAGE_SIZES`).
IMAGE_SIZE_CHOICES = (512, 1024, 2048, 4096, 8192)

#: How palette noise picks its colours: name -> (label, description), in the order the panel lists them.
NOISE_MAPPINGS = {
    "random": ("Random", "Any palette colour, by its weight, for the chosen share of points (the recipe of "
                         "Naden, März and Macdonald, 2014, for surfaces painted in the palette's colours)"),
    "tone": ("By Tone and Hue", "The picture's colours mapped onto the palette by tone and hue (a grey sky to "
                                "its blues, a yellow to its yellows; Fidelity keeps the picture's own); the chosen "
                                "share of points picks a palette colour near its own (keeps the picture)"),
}

#: The modes whose strokes can follow a direction (:data:`DIRECTIONS`).
DIRECTED_MODES = ("ced", "flow")


def takes_direction(mode, strokes=0.0, hatch_spacing=0.0):
    """Whether a run follows a direction (:data:`DIRECTIONS`): in the modes of :data:`DIRECTED_MODES`, and in
    any mode with brush strokes or hatching."""
    return mode in DIRECTED_MODES or strokes > 0 or hatch_spacing > 0


def paints_shading(shade_light=0.0, shade_edges=0.0):
    """Whether a run paints the form's light or edges into the colour (:mod:`cp_stylize.shading`); its
    Warm and Cool setting acts only then."""
    return shade_light > 0 or shade_edges > 0


#: Mode names, in the core's order.
MODES = ("gaussian", "perona_malik", "eed", "ced", "beltrami", "flow")

#: Default filter parameters by mode.
DEFAULTS = {mode: dict(FILTERS[mode].defaults) for mode in MODES}

assert set(MODES) == set(FILTERS)
