"""The add-on's settings, stored on the scene as ``scene.cp_stylize``.

Lengths and times are relative to the object's size: the object is normalised
so that its longest side is 2 (as in the paper), so a setting looks the same on
a 2 cm object and on a 20 m one.  :meth:`CPStylizeSettings.to_settings` is the
one place where the properties become the core's frozen StylizeSettings.
"""

import bpy

#: Grid spacing relative to an object whose longest side is 2, by quality.
QUALITY_SPACING = {"PREVIEW": 0.016, "STANDARD": 0.008, "HIGH": 0.005}

MODE_ITEMS = [
    ("ced", "Coherence-Enhancing", "Weickert's CED: smooths along the flow of the texture, painterly strokes"),
    ("eed", "Edge-Enhancing", "Weickert's EED: removes noise, keeps edges sharp"),
    ("perona_malik", "Perona-Malik", "Edge-stopping smoothing"),
    ("gaussian", "Gaussian", "Uniform blur on the surface"),
    ("beltrami", "Beltrami", "Colour Beltrami flow: smooths regions, sharpens colour edges"),
]


class CPStylizePaletteColour(bpy.types.PropertyGroup):
    colour: bpy.props.FloatVectorProperty(name="Colour", subtype="COLOR_GAMMA", size=3, min=0.0, max=1.0,
                                          default=(0.1, 0.15, 0.3))
    weight: bpy.props.FloatProperty(name="Weight", description="How often this colour is drawn, relative to the others",
                                    default=1.0, min=0.0, soft_max=10.0)


class CPStylizeSettings(bpy.types.PropertyGroup):
    preset_name: bpy.props.StringProperty(name="Preset", description="The preset last loaded", default="")
    mode: bpy.props.EnumProperty(name="Mode", items=MODE_ITEMS, default="ced")
    quality: bpy.props.EnumProperty(
        name="Quality",
        description="Grid spacing of the computational band, relative to the object's size",
        items=[
            ("PREVIEW", "Preview", "Coarse grid (h = 0.016 for an object 2 units long): quick"),
            ("STANDARD", "Standard", "h = 0.008 for an object 2 units long, the paper's grid"),
            ("HIGH", "High", "h = 0.005 for an object 2 units long: fine strokes, about 2.5 times "
                             "the memory and time of Standard"),
            ("CUSTOM", "Custom", "Set the relative grid spacing yourself"),
        ],
        default="PREVIEW",
    )
    spacing: bpy.props.FloatProperty(
        name="Grid Spacing", description="Grid spacing h for the object normalised to a longest side of 2",
        default=0.008, min=0.002, max=0.1, precision=4, step=0.1,
    )
    time: bpy.props.FloatProperty(
        name="Time", description="Diffusion time T (squared lengths of the object normalised to 2): "
                                 "how far the filter goes. The blur radius grows like sqrt(2 T)",
        default=1.1e-4, min=1e-6, max=0.1, precision=6, step=0.001,
    )
    sigma: bpy.props.FloatProperty(
        name="Pre-smoothing", description="Structure tensor pre-smoothing time sigma (noise scale ignored)",
        default=1e-4, min=0.0, max=0.01, precision=6, step=0.001,
    )
    rho: bpy.props.FloatProperty(
        name="Integration", description="Structure tensor integration time rho (size of the neighbourhood "
                                        "whose orientation the strokes follow)",
        default=5e-4, min=0.0, max=0.05, precision=6, step=0.001,
    )
    alpha: bpy.props.FloatProperty(
        name="Alpha", description="CED: smallest diffusivity, across the flow (0 to 1)",
        default=1e-3, min=0.0, max=1.0, precision=4, step=0.01,
    )
    b_rel: bpy.props.FloatProperty(
        name="Coherence Threshold", description="CED: B relative to the largest coherence of the input; "
                                                "smaller values draw strokes in weaker structure",
        default=1e-3, min=0.0, max=1.0, precision=7, step=0.0001,
    )
    lambda_rel: bpy.props.FloatProperty(
        name="Edge Threshold", description="EED, Perona-Malik, Beltrami: edge sensitivity lambda relative to the "
                                           "input's largest coherence or gradient",
        default=1e-3, min=1e-6, max=10.0, precision=5, step=0.01,
    )
    noise_fraction: bpy.props.FloatProperty(
        name="Noise", description="Share of the band points replaced by palette colours before the filter "
                                  "(painterly looks; 0 for none)",
        default=0.0, min=0.0, max=1.0, subtype="FACTOR",
    )
    palette: bpy.props.CollectionProperty(type=CPStylizePaletteColour)
    seed: bpy.props.IntProperty(name="Seed", description="Random seed of the noise", default=0, min=0)
    image_size: bpy.props.EnumProperty(
        name="Image Size", items=[(s, s, f"{s} x {s} pixels") for s in ("512", "1024", "2048", "4096")],
        default="1024",
    )
    image_name: bpy.props.StringProperty(name="Image Name", description="Name of the new image "
                                                                         "(empty: <object>_stylized)")
    target: bpy.props.EnumProperty(
        name="Material",
        items=[("NEW_MATERIAL", "New Material Copy", "Wire the result into a copy of each material; "
                                                      "the originals stay as they are"),
               ("APPLY", "Apply to This Material", "Wire the result into the object's own materials")],
        default="NEW_MATERIAL",
    )
    storage: bpy.props.EnumProperty(
        name="Image", items=[("PACK", "Pack", "Pack the image into the .blend file"),
                             ("SAVE", "Save Next to .blend", "Save a PNG next to the .blend file")],
        default="PACK",
    )
    memory_limit: bpy.props.FloatProperty(
        name="Memory Limit", description="Refuse runs whose estimated memory is above this (GiB)",
        default=8.0, min=0.1, max=1024.0, precision=1,
    )

    def relative_spacing(self):
        return self.spacing if self.quality == "CUSTOM" else QUALITY_SPACING[self.quality]

    def to_settings(self):
        """The core's StylizeSettings for these properties."""
        from ..presets import StylizeSettings

        mode = self.mode
        params = {}
        if mode in ("eed", "ced"):
            params.update(sigma=self.sigma, rho=self.rho)
        if mode in ("perona_malik", "beltrami"):
            params.update(sigma=self.sigma)
        if mode == "ced":
            params.update(alpha=self.alpha, b_rel=self.b_rel)
        if mode in ("eed", "perona_malik", "beltrami"):
            params.update(lambda_rel=self.lambda_rel)
        return StylizeSettings(
            mode=mode, T=self.time, spacing=self.relative_spacing(), noise_fraction=self.noise_fraction,
            palette=tuple(tuple(p.colour) for p in self.palette),
            palette_weights=tuple(p.weight for p in self.palette), seed=self.seed,
            image_size=int(self.image_size), name=self.preset_name, **params)

    def from_settings(self, settings):
        """Set the filter properties from StylizeSettings (a loaded preset); output settings stay."""
        from ..diffusion import DEFAULTS

        self.preset_name = settings.name
        self.mode = settings.mode
        self.time = settings.T
        spacing = {v: k for k, v in QUALITY_SPACING.items()}.get(settings.spacing)
        self.quality = spacing or "CUSTOM"
        self.spacing = settings.spacing
        defaults = DEFAULTS[settings.mode]
        for key in ("sigma", "rho", "alpha", "b_rel", "lambda_rel"):
            value = getattr(settings, key)
            if value is None:
                value = defaults.get(key)
            if value is not None:
                setattr(self, key, value)
        self.noise_fraction = settings.noise_fraction
        self.seed = settings.seed
        self.palette.clear()
        weights = settings.palette_weights or (1.0,) * len(settings.palette)
        for colour, weight in zip(settings.palette, weights):
            item = self.palette.add()
            item.colour, item.weight = colour, weight


classes = (CPStylizePaletteColour, CPStylizeSettings)
