"""The add-on's settings, stored on the scene as ``scene.cp_stylize``.

Lengths and times are relative to the object's size: the object is normalised
so that its diameter is 2 (as in the paper), so a setting looks the same on
a 2 cm object and on a 20 m one.  The properties, their limits, defaults and
descriptions come from :mod:`cp_stylize.parameters`, the core's one table.
Each mode keeps its own filter parameters (``ced_rho``, ``eed_rho``, ...), so
switching modes never carries one filter's values into another;
``settings.rho`` and the like read and set the current mode's.

The panel shows lengths and times as sizes in the scene's units, for the
active object: each has a view, ``<property>_size`` (``time_size``,
``stroke_width_size``, ``eed_sigma_size``), that reads and sets the stored
relative value through the object's size (:func:`object_scale`) and
:meth:`cp_stylize.parameters.Parameter.size` (a time as the radius of the blur
it matches).  The stored values stay relative, so a preset looks the same on
any object; the views hold nothing of their own.
:meth:`CPStylizeSettings.to_settings` is the one place where the properties
become the core's frozen StylizeSettings, :meth:`~CPStylizeSettings.output`
the one place for what to do with the result.
"""

import bpy

from ..parameters import (AXIS_DIRECTIONS, DIRECTIONS, FILTER_PARAMETERS, FILTERS, IMAGE_SIZE_CHOICES, NOISE_MAPPINGS,
                          RUN, SEED_LIMITS, takes_direction)

#: Grid spacing relative to an object whose diameter is 2, by quality.
QUALITY_SPACING = {"PREVIEW": 0.016, "STANDARD": 0.008, "HIGH": 0.005}

#: Run parameters shown as sliders: the ratios (shares from 0 to 1).
FACTORS = tuple(p.name for p in RUN.values() if p.unit == "ratio")

#: Property names that differ from the core's parameter names.
PROPERTY_NAMES = {"T": "time"}


def _float_property(parameter, default=None, **options):
    return bpy.props.FloatProperty(
        name=parameter.label, description=parameter.description,
        default=parameter.default if default is None else default,
        min=parameter.minimum, max=parameter.maximum, precision=parameter.precision, step=parameter.step, **options)


def filter_property(mode, name):
    """The property that holds filter parameter ``name`` of ``mode``: each mode keeps its own values."""
    return f"{mode}_{name}"


def _current(name):
    """A Python property for the current mode's value of filter parameter ``name`` (for scripts)."""
    def get(self):
        if name not in FILTERS[self.mode].defaults:
            raise AttributeError(f"mode {self.mode!r} has no parameter {name!r}")
        return getattr(self, filter_property(self.mode, name))

    def set(self, value):
        if name not in FILTERS[self.mode].defaults:
            raise AttributeError(f"mode {self.mode!r} has no parameter {name!r}")
        setattr(self, filter_property(self.mode, name), value)
    return property(get, set, doc=f"{FILTER_PARAMETERS[name].label} of the current mode")


_scales = {}


def object_scale(obj=None):
    """Half the surface's diameter in world units (what a relative length of 1 is on the object) for ``obj``,
    by default the active object; None without a mesh object, or for one whose surface the core cannot
    read.  Kept for the object as it is (its name, size and counts), since the panel asks at every redraw."""
    obj = obj if obj is not None else getattr(bpy.context, "active_object", None)
    if obj is None or obj.type != "MESH":
        return None
    key = (obj.name, tuple(round(c, 6) for c in obj.dimensions), len(obj.data.vertices), len(obj.data.polygons))
    if key not in _scales:
        from ..pipeline import normalisation
        from . import meshdata

        try:
            mesh = meshdata.read(obj, None, corners=False)
            scale = 1.0 / normalisation(mesh.vertices, mesh.triangles)[1]
        except ValueError:          # StylizeError too: the panel says why elsewhere
            scale = None
        _scales.clear()
        _scales[key] = scale
    return _scales[key]


def size_property(name):
    """The size view of the property ``name`` (a length or time)."""
    return f"{name}_size"


def _size_view(name, parameter):
    """The size view of property ``name`` holding ``parameter``: in the scene's units for the active object
    (an object 2 units across without one)."""
    def get(self):
        return parameter.size(getattr(self, name)) * (object_scale() or 1.0)

    def set(self, size):
        setattr(self, name, parameter.from_size(size / (object_scale() or 1.0)))
    return bpy.props.FloatProperty(
        name=parameter.size_label, description=f"{parameter.description}. Shown as a size on the active object",
        subtype="DISTANCE", unit="LENGTH", precision=3, step=1, min=0.0, get=get, set=set)


def _mode_changed(self, context):
    """Flow needs a direction field: leaving the texture's own for it, take the minimum curvature."""
    if self.mode == "flow" and self.direction == "texture":
        self.direction = "min"


class CPStylizePaletteColour(bpy.types.PropertyGroup):
    colour: bpy.props.FloatVectorProperty(name="Colour", subtype="COLOR_GAMMA", size=3, min=0.0, max=1.0,
                                          default=(0.1, 0.15, 0.3))
    weight: bpy.props.FloatProperty(name="Weight", description="How often this colour is drawn, relative to the others",
                                    default=1.0, min=0.0, soft_max=10.0)


class CPStylizeSettings(bpy.types.PropertyGroup):
    preset_name: bpy.props.StringProperty(name="Preset", description="The preset last loaded", default="")
    preset_key: bpy.props.StringProperty(name="Preset Key", description="The key (or file) of the preset last "
                                                                        "loaded or saved", default="")
    mode: bpy.props.EnumProperty(name="Mode", items=[(f.name, f.label, f.description) for f in FILTERS.values()],
                                 default="ced", update=_mode_changed)
    direction: bpy.props.EnumProperty(
        name="Stroke Direction", description="What the strokes of CED and Flow, and the brush strokes, follow",
        items=[(name, label, description) for name, (label, description) in DIRECTIONS.items()], default="texture")
    axis: bpy.props.FloatVectorProperty(
        name="Axis", description="The direction the strokes follow, in the object's space; projected onto the "
                                 "surface, and the texture's own where the surface faces it",
        size=3, subtype="XYZ", default=(0.0, 0.0, 1.0))
    direction_attribute: bpy.props.StringProperty(
        name="Attribute", description="The mesh's vector attribute (on points, corners or faces) the strokes follow")
    quality: bpy.props.EnumProperty(
        name="Quality",
        description="Grid spacing of the computational band, relative to the object's size",
        items=[
            ("PREVIEW", "Preview", "Coarse grid (h = 0.016 for an object 2 units across): quick"),
            ("STANDARD", "Standard", "h = 0.008 for an object 2 units across, the grid most presets use"),
            ("HIGH", "High", "h = 0.005 for an object 2 units across: fine strokes, about 2.5 times "
                             "the memory and time of Standard"),
            ("CUSTOM", "Custom", "Set the relative grid spacing yourself"),
        ],
        default="PREVIEW",
    )
    palette: bpy.props.CollectionProperty(type=CPStylizePaletteColour)
    noise_mapping: bpy.props.EnumProperty(
        name="Colours", description="How the noise picks its palette colours",
        items=[(name, label, description) for name, (label, description) in NOISE_MAPPINGS.items()],
        default="random")
    seed: bpy.props.IntProperty(name="Seed", description="Random seed of the noise and the strokes", default=0,
                                min=SEED_LIMITS[0], max=SEED_LIMITS[1])
    image_size: bpy.props.EnumProperty(
        name="Image Size", items=[(str(s), str(s), f"{s} x {s} pixels") for s in IMAGE_SIZE_CHOICES],
        default="1024",
    )
    image_name: bpy.props.StringProperty(name="Image Name", description="Name of the new image "
                                                                         "(empty: <object>_stylized)")
    result_kind: bpy.props.EnumProperty(
        name="Result",
        items=[("IMAGE", "Image", "An image on a UV atlas (the mesh's own UVs, or a new UV map), wired into the "
                                  "material"),
               ("ATTRIBUTE", "Colour Attribute", "A new colour attribute of the mesh, from the colour attribute it "
                                                 "shows (a scan, vertex paint), wired into the material: no image and "
                                                 "no UV map; filtered on the mesh's own vertices where they lie "
                                                 "closer than the grid, else on the band. Filters only: a look that "
                                                 "paints needs an image")],
        default="IMAGE",
    )
    target: bpy.props.EnumProperty(
        name="Material",
        items=[("NEW_MATERIAL", "New Material Copy", "Wire the result into a copy of each material, for this "
                                                      "object only; the originals stay as they are"),
               ("APPLY", "Apply to This Material", "Wire the result into the object's own materials (every "
                                                   "object using them changes)")],
        default="NEW_MATERIAL",
    )
    storage: bpy.props.EnumProperty(
        name="Image", items=[("PACK", "Pack", "Pack the image into the .blend file"),
                             ("SAVE", "Save Next to .blend", "Save a PNG next to the .blend file (never over an "
                                                             "existing file)")],
        default="PACK",
    )
    memory_limit: bpy.props.FloatProperty(
        name="Max RAM (GiB)", description="Refuse runs whose estimated memory is above this (GiB); runs that need "
                                         "more than this computer has are always refused",
        default=8.0, min=0.1, max=1024.0, precision=1,
    )
    time_limit: bpy.props.FloatProperty(
        name="Max Time (min)", description="Refuse runs whose estimated time is above this (minutes)",
        default=15.0, min=0.5, max=24 * 60.0, precision=1,
    )
    keep: bpy.props.BoolProperty(
        name="Keep for Re-runs", description="Keep the band, its operators and the atlas in memory after a run, so "
                                             "that the next run on the same mesh and grid starts at the filter",
        default=True,
    )

    def relative_spacing(self):
        return self.spacing if self.quality == "CUSTOM" else QUALITY_SPACING[self.quality]

    def to_settings(self):
        """The core's StylizeSettings for these properties."""
        from ..settings import StylizeSettings

        params = {p.name: getattr(self, filter_property(self.mode, p.name)) for p in FILTERS[self.mode].parameters}
        direction = self.direction if takes_direction(self.mode, self.strokes, self.hatch_spacing) else None
        # the axis where it is used or usable (a zeroed axis must not stop an attribute run), so a preset keeps it
        axis = {"axis": tuple(self.axis)} if direction in AXIS_DIRECTIONS or any(self.axis) else {}
        run = {name: getattr(self, PROPERTY_NAMES.get(name, name)) for name in RUN}
        run["spacing"] = self.relative_spacing()
        return StylizeSettings(
            mode=self.mode, **run, noise_mapping=self.noise_mapping,
            palette=tuple(tuple(p.colour) for p in self.palette),
            palette_weights=tuple(p.weight for p in self.palette), seed=self.seed,
            image_size=int(self.image_size), name=self.preset_name, params=params,
            direction=direction, attribute=self.direction_attribute, **axis)

    def output(self):
        """What to do with a run's result, and its limits (the Output panel)."""
        from .operators import machine_speed
        from .stylize import Output

        return Output(image_name=self.image_name, target=self.target, storage=self.storage,
                      memory_limit=self.memory_limit * 2**30, time_limit=self.time_limit * 60, keep=self.keep,
                      speed=machine_speed(), kind=self.result_kind)

    def from_settings(self, settings, key=""):
        """Set the filter properties from StylizeSettings (a loaded preset, ``key`` its key); output settings stay.

        All or nothing: the settings are checked whole when they are made, and
        should setting a property fail all the same, every property is put
        back as it was before the error is raised.
        """
        kept = self._filter_state()
        try:
            self._set_filter(settings)
            self.preset_key = key
        except BaseException:
            self._set_state(kept)
            raise

    def _set_filter(self, settings):
        self.preset_name = settings.name
        self.mode = settings.mode
        for name in RUN:
            setattr(self, PROPERTY_NAMES.get(name, name), getattr(settings, name))
        spacing = {v: k for k, v in QUALITY_SPACING.items()}.get(settings.spacing)
        self.quality = spacing or "CUSTOM"
        for name, default in FILTERS[settings.mode].defaults.items():
            setattr(self, filter_property(settings.mode, name), settings.params.get(name, default))
        self.direction = settings.stroke_direction
        self.axis = settings.axis
        self.direction_attribute = settings.attribute
        self.noise_mapping = settings.noise_mapping
        self.seed = settings.seed
        self.palette.clear()
        weights = settings.palette_weights or (1.0,) * len(settings.palette)
        for colour, weight in zip(settings.palette, weights):
            item = self.palette.add()
            item.colour, item.weight = colour, weight

    def _filter_state(self):
        """Every property a preset sets, and the palette, as plain values."""
        values = {name: getattr(self, name) for name in self.bl_rna.properties.keys()
                  if name not in _OUTPUT and name not in SIZE_VIEWS and name != "rna_type" and name != "palette"}
        values = {name: tuple(v) if hasattr(v, "__len__") and not isinstance(v, str) else v
                  for name, v in values.items()}
        return values, [(tuple(p.colour), p.weight) for p in self.palette]

    def _set_state(self, state):
        values, palette = state
        for name, value in values.items():
            setattr(self, name, value)
        self.palette.clear()
        for colour, weight in palette:
            item = self.palette.add()
            item.colour, item.weight = colour, weight


#: The properties of the Output panel: a preset leaves them as they are.
_OUTPUT = {"result_kind", "image_size", "image_name", "target", "storage", "memory_limit", "time_limit", "keep"}


def _run_property(parameter):
    """The property of a run parameter: a whole number for a count, else a float (a slider for shares)."""
    if parameter.unit == "count":
        return bpy.props.IntProperty(name=parameter.label, description=parameter.description,
                                     default=int(parameter.default), min=int(parameter.minimum),
                                     max=int(parameter.maximum))
    return _float_property(parameter, **({"subtype": "FACTOR"} if parameter.name in FACTORS else {}))


#: The size views (names) of the lengths and times.
SIZE_VIEWS = set()


def _annotate(name, prop, parameter):
    """Add the property ``prop`` under ``name`` to the settings, and its size view where ``parameter`` is a
    length or a time."""
    CPStylizeSettings.__annotations__[name] = prop
    if parameter.sized:
        SIZE_VIEWS.add(size_property(name))
        CPStylizeSettings.__annotations__[size_property(name)] = _size_view(name, parameter)


for _parameter in RUN.values():
    _annotate(PROPERTY_NAMES.get(_parameter.name, _parameter.name), _run_property(_parameter), _parameter)
for _mode, _filter in FILTERS.items():
    for _parameter in _filter.parameters:
        _annotate(filter_property(_mode, _parameter.name),
                  _float_property(_parameter, default=_filter.defaults[_parameter.name]), _parameter)
for _name in FILTER_PARAMETERS:
    setattr(CPStylizeSettings, _name, _current(_name))

classes = (CPStylizePaletteColour, CPStylizeSettings)
