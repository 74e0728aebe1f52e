"""A copy of a USD or glTF scene with each light's answer written in (`--write-back OUT`).

* glTF (`OUT.gltf`): each `KHR_lights_punctual` light gets the chosen `range` (the extension's
  own property; the published range was one candidate of the choice, not a bound) and the
  answer in `extras.attenfit` (family, parameters, errors, engine properties). glTF has
  no area light extension: an answer with an engine's own area light is recorded there,
  with a note, and the light's entry is left as it is (never an invalid light). Buffers and
  image files are embedded as `data:` URIs so the copy stands alone wherever it is written;
  only files inside the scene's folder are read (`_refs`): a reference outside it is refused
  before anything is written. The rest of the JSON is kept as written.
* USD (`OUT.usda`): the composed stage, flattened into one layer (references and sublayers
  resolved, so the copy stands alone), with custom attributes in the `attenfit:` namespace
  on each light prim: `attenfit:family`, `attenfit:range`, `attenfit:error`,
  `attenfit:checkedError`, `attenfit:params:NAME`, `attenfit:engine` and
  `attenfit:<engine>:PROPERTY` (an engine's own area light, `attenfit._scenes._engine_area`:
  its `light_type` and size, range and intensity properties, as for a punctual light; a
  vector property as a double array); lengths in the stage's units (`metersPerUnit`, recorded as
  `attenfit:metersPerUnit` and in each length's doc string), engine properties in the
  engine's.

No file the scene reads is ever replaced (every layer of a USD stage, every glTF buffer:
`ImportedScene.inputs`); the copy is written atomically, and an existing file is replaced
only with `force` and only when it is attenfit's own write-back (`WRITE_BACK_MARKS`).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .._atomic import atomic_write, check_output_path, check_own_output
from .._errors import AttenfitError, BadValueError, DataFileError
from ._choices import LightChoice
from ._files import ImportedScene
from ._usd_layers import pxr_error, usd_diagnostics, usd_layers

__all__ = ["WRITE_BACK_MARK", "WRITE_BACK_MARKS", "write_back"]

#: The key of the `customLayerData` entry that marks a USD copy as attenfit's write-back
#: (its value: the scene's file name); only a file with it is replaced with `force`.
WRITE_BACK_MARK = "attenfitWriteBack"
#: What a file attenfit wrote back holds (a USD copy: the mark, or the `attenfit:`
#: attributes of copies written before it; a glTF copy: `extras.attenfit`): with `force`, an
#: existing file is replaced only when it holds one.
WRITE_BACK_MARKS = (WRITE_BACK_MARK, "attenfit:family", '"attenfit"')


def _answer(c: LightChoice, engine: str | None) -> dict[str, Any]:
    out = {
        "family": c.family,
        "status": c.status,
        "params": dict(c.params),
        "error": c.error,
        "checked_error": c.checked_error,
    }
    if c.engine_error is not None:
        out["engine_error"] = c.engine_error
    if c.spot is not None:
        out["spot"] = dict(c.spot)
    if c.range is not None and c.range.get("range") is not None:
        out["range"] = c.range["range"]
        out["threshold"] = c.range["threshold"]
    if engine is not None:
        out["engine"] = engine
        out["properties"] = dict(c.properties)
    return out


def write_back(
    imported: ImportedScene,
    choices: Sequence[LightChoice],
    out: str | os.PathLike,
    *,
    force: bool = False,
) -> Path:
    """Write the copy of `imported`'s file with `choices` into `out` (see the module
    docstring); returns `out`."""
    out = Path(out)
    want = ".gltf" if imported.format == "gltf" else ".usda"
    if out.suffix.lower() != want:
        raise BadValueError(
            f"--write-back {str(out)!r}: a {imported.format.upper()} scene is written back as "
            f"a {want} file"
        )
    check_output_path(out, force=force, inputs=imported.inputs or (imported.path,))
    if force:
        check_own_output(out, marks=WRITE_BACK_MARKS)
    engine = imported.engine.name if imported.engine is not None else None
    if imported.format == "gltf":
        text = _gltf_text(imported, choices, engine)
    else:
        text = _usd_text(imported, choices, engine)
    return atomic_write(out, text, force=force)


def _gltf_text(imported: ImportedScene, choices: Sequence[LightChoice], engine) -> str:
    from ._gltf import embedded_document

    label = imported.path.name
    doc = embedded_document(imported.path, label)  # files outside its folder: refused
    lights = ((doc.get("extensions") or {}).get("KHR_lights_punctual") or {}).get("lights") or []
    for c in choices:
        j = imported.refs[c.light]
        if not (isinstance(j, int) and j < len(lights)):
            raise BadValueError(f"{label}: changed while it was answered (light {j} is gone)")
        d = lights[j]
        where = f"{label}: extensions.KHR_lights_punctual.lights[{j}].extras"
        extras = d.setdefault("extras", {})
        if not isinstance(extras, dict):
            raise BadValueError(
                f"{where}: is not a JSON object; the answer goes in extras.attenfit"
            )
        answers = extras.setdefault("attenfit", [])
        if not isinstance(answers, list):
            raise BadValueError(f"{where}.attenfit: is not a list; attenfit appends its answers")
        R = c.range.get("range") if c.range is not None else None
        answer = {"node_light": c.name, **_answer(c, engine)}
        if "light_type" in (c.properties or {}):
            # an engine's own area light: KHR_lights_punctual has none (point, spot,
            # directional only), so the light is left as it is and the answer only recorded
            answer["note"] = (
                f"{c.properties['light_type']} is {engine}'s own area light; glTF has no area "
                "light extension, so this light's KHR_lights_punctual entry is unchanged"
            )
        elif R is not None and R > 0 and math.isfinite(R):
            d["range"] = float(R)  # the chosen range (the published one was a candidate)
        answers.append(answer)
    return json.dumps(doc, indent=1) + "\n"


def _usd_text(imported: ImportedScene, choices: Sequence[LightChoice], engine) -> str:
    """The flattened stage with the answers, lengths in the stage's units: `attenfit:range`
    and each length parameter (`Family.length_power`: a length, an area, 1/length^2...)
    divided by metersPerUnit to that power, `attenfit:threshold` (irradiance, per m^2)
    times metersPerUnit^2; each such attribute's doc string names the unit, and
    `attenfit:metersPerUnit` records the factor. Engine properties stay in the engine's own
    units (what is typed into the engine)."""
    from pxr import Sdf, Usd, UsdGeom

    label = imported.path.name
    with usd_diagnostics():  # usd-core's warnings: reported when the scene was read
        layers = usd_layers(imported.path, label)  # checked again: the files may have changed
        try:
            flat = Usd.Stage.Open(layers.root).Flatten()
        except Exception as exc:  # pxr raises Tf.ErrorException
            raise DataFileError(
                f"{label}: cannot be flattened by usd-core ({pxr_error(exc)})"
            ) from None
    flat.customLayerData = {**flat.customLayerData, WRITE_BACK_MARK: label}
    stage = Usd.Stage.Open(flat)
    mpu = float(UsdGeom.GetStageMetersPerUnit(stage))
    for c in choices:
        path = str(imported.refs[c.light])
        prim = _editable(stage, path)
        if prim is None:
            raise BadValueError(
                f"--write-back: {label}: light {path} is not in the flattened scene (the "
                "file changed while attenfit read it?)"
            )
        ans = _answer(c, engine)

        def put(name: str, value: Any, power: int = 0, prim=prim) -> None:
            if isinstance(value, bool):
                prim.CreateAttribute(name, Sdf.ValueTypeNames.Bool, custom=True).Set(value)
            elif isinstance(value, int | float):
                attr = prim.CreateAttribute(name, Sdf.ValueTypeNames.Double, custom=True)
                attr.Set(float(value) / mpu**power)
                if power:
                    attr.SetDocumentation(_unit_doc(power, mpu))
            elif isinstance(value, str):
                prim.CreateAttribute(name, Sdf.ValueTypeNames.String, custom=True).Set(value)
            elif isinstance(value, list | tuple) and all(_is_num(v) for v in value):
                # a vector property (Godot's AreaLight3D area_size): a double array
                attr = prim.CreateAttribute(name, Sdf.ValueTypeNames.DoubleArray, custom=True)
                attr.Set([float(v) for v in value])

        put("attenfit:metersPerUnit", mpu)
        powers = {"range": 1, "threshold": -2}
        for key in ("family", "status", "error", "checked_error", "range", "threshold", "engine"):
            if ans.get(key) is not None:
                put(f"attenfit:{_camel(key)}", ans[key], powers.get(key, 0))
        for k, v in ans["params"].items():
            put(f"attenfit:params:{k}", v, _length_power(c, k))
        for k, v in (ans.get("spot") or {}).items():
            put(f"attenfit:spot:{k}", v)
        for k, v in (ans.get("properties") or {}).items():
            put(f"attenfit:{engine}:{k}", v)
    return stage.GetRootLayer().ExportToString()


def _length_power(c: LightChoice, param: str) -> int:
    """The power of length in the unit of the chosen family's parameter `param` (0 when
    the family does not say)."""
    from .._curves import get_family

    model = c.model
    try:
        if model is None:
            cls = get_family(c.family) if c.family is not None else None
        else:
            cls = model if isinstance(model, type) else type(model)
        return int(cls.length_power(param)) if cls is not None else 0
    except (AttributeError, AttenfitError):
        return 0


def _unit_doc(power: int, mpu: float) -> str:
    unit = {1: "stage units", 2: "stage units^2", -2: "per stage unit^2"}.get(
        power, f"stage units^{power}"
    )
    return f"attenfit: in {unit} (metersPerUnit {mpu:g}: x {mpu**power:g} for metres)"


def _editable(stage, path: str):
    """The prim at `path`, made editable: a light inside an instance (an instance proxy,
    shared by every instance of its prototype) gets its own copy by making the instances
    above it not instanceable in the written copy, so each instance keeps its own answer."""
    prim = stage.GetPrimAtPath(path)
    for _ in range(path.count("/") + 1):  # an instance inside an instance: once per level
        if not prim.IsValid() or not prim.IsInstanceProxy():
            break
        top = prim.GetParent()
        while top.IsValid() and not top.IsInstance():
            top = top.GetParent()
        if not top.IsValid():
            break
        top.SetInstanceable(False)
        prim = stage.GetPrimAtPath(path)
    return prim if prim.IsValid() and not prim.IsInstanceProxy() else None


def _is_num(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _camel(key: str) -> str:
    head, *rest = key.split("_")
    return head + "".join(w.title() for w in rest)
