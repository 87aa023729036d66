"""The model description (modelDescription.xml) of an FMU, FMI 2 or 3, and FMI 3's build
description (sources/buildDescription.xml).

Input: an `FmuModel` and the names of the source files. Output: XML text, byte-reproducible
(attributes in a fixed order, numbers as Python's shortest round-trip repr, no dates).

Example:
    >>> import s2gen
    >>> from s2gen.fmi.model import describe
    >>> model = describe(s2gen.load("double_pendulum"), fmi=2, kind="cs", method="vi")
    >>> text = model_description(model, ("double_pendulum.c",), "s2gen")
    >>> '<ScalarVariable name="q1_x" valueReference="7"' in text
    True
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from s2gen.fmi.model import FmuModel, Variable

__all__ = ["LOG_CATEGORY", "build_description", "model_description"]

#: The log category of every message the wrapper logs (declared in the description).
LOG_CATEGORY = "logStatusError"


def _number(value: float) -> str:
    return repr(float(value))


def _text(root: ET.Element) -> str:
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, "unicode") + "\n"


def _experiment(model: FmuModel, parent: ET.Element) -> None:
    e = model.default_experiment
    attrs = {"startTime": _number(e.start_time)}
    if e.stop_time is not None:
        attrs["stopTime"] = _number(e.stop_time)
    attrs["stepSize"] = _number(e.step_size)
    ET.SubElement(parent, "DefaultExperiment", attrs)


def _common(v: Variable) -> dict[str, str]:
    attrs = {"name": v.name, "valueReference": str(v.vr), "description": v.description}
    attrs["causality"] = v.causality.value
    attrs["variability"] = v.variability
    if v.initial is not None and v.causality.value != "parameter":
        attrs["initial"] = v.initial
    return attrs


def _initial_unknowns(model: FmuModel) -> list[Variable]:
    return [v for v in model.variables if v.initial == "calculated"]


def _outputs(model: FmuModel) -> list[Variable]:
    return [v for v in model.variables if v.causality.value == "output"]


def _fmi2(model: FmuModel, sources: tuple[str, ...], tool: str) -> ET.Element:
    root = ET.Element(
        "fmiModelDescription",
        {
            "fmiVersion": "2.0",
            "modelName": model.name,
            "guid": model.guid,
            "description": model.description,
            "generationTool": tool,
            "variableNamingConvention": "structured",
            "numberOfEventIndicators": "0",
        },
    )
    for tag, wanted in (
        ("ModelExchange", model.model_exchange),
        ("CoSimulation", model.co_simulation),
    ):
        if not wanted:
            continue
        attrs = {"modelIdentifier": model.name}
        if tag == "CoSimulation":
            attrs["canHandleVariableCommunicationStepSize"] = "true"
        element = ET.SubElement(root, tag, attrs)
        files = ET.SubElement(element, "SourceFiles")
        for name in sources:
            ET.SubElement(files, "File", {"name": name})
    categories = ET.SubElement(root, "LogCategories")
    ET.SubElement(categories, "Category", {"name": LOG_CATEGORY, "description": "errors"})
    _experiment(model, root)
    variables = ET.SubElement(root, "ModelVariables")
    index = {v.vr: k + 1 for k, v in enumerate(model.variables)}
    for v in model.variables:
        attrs = _common(v)
        element = ET.SubElement(variables, "ScalarVariable", attrs)
        real = {}
        if v.start is not None:
            real["start"] = _number(v.start)
        if v.derivative_of is not None:
            real["derivative"] = str(index[v.derivative_of])
        ET.SubElement(element, "Real", real)
    structure = ET.SubElement(root, "ModelStructure")
    groups = (
        ("Outputs", _outputs(model)),
        ("Derivatives", [v for v in model.variables if v.derivative_of is not None]),
        ("InitialUnknowns", _initial_unknowns(model)),
    )
    for tag, members in groups:
        if members:
            group = ET.SubElement(structure, tag)
            for v in members:
                ET.SubElement(group, "Unknown", {"index": str(index[v.vr])})
    return root


def _fmi3(model: FmuModel, tool: str) -> ET.Element:
    root = ET.Element(
        "fmiModelDescription",
        {
            "fmiVersion": "3.0",
            "modelName": model.name,
            "instantiationToken": model.guid,
            "description": model.description,
            "generationTool": tool,
            "variableNamingConvention": "structured",
        },
    )
    if model.model_exchange:
        ET.SubElement(root, "ModelExchange", {"modelIdentifier": model.name})
    if model.co_simulation:
        ET.SubElement(
            root,
            "CoSimulation",
            {"modelIdentifier": model.name, "canHandleVariableCommunicationStepSize": "true"},
        )
    categories = ET.SubElement(root, "LogCategories")
    ET.SubElement(categories, "Category", {"name": LOG_CATEGORY, "description": "errors"})
    _experiment(model, root)
    variables = ET.SubElement(root, "ModelVariables")
    for v in model.variables:
        attrs = _common(v)
        if v.start is not None:
            attrs["start"] = _number(v.start)
        if v.derivative_of is not None:
            attrs["derivative"] = str(v.derivative_of)
        ET.SubElement(variables, "Float64", attrs)
    structure = ET.SubElement(root, "ModelStructure")
    for v in _outputs(model):
        ET.SubElement(structure, "Output", {"valueReference": str(v.vr)})
    for v in model.variables:
        if v.derivative_of is not None:
            ET.SubElement(structure, "ContinuousStateDerivative", {"valueReference": str(v.vr)})
    for v in _initial_unknowns(model):
        ET.SubElement(structure, "InitialUnknown", {"valueReference": str(v.vr)})
    return root


def model_description(model: FmuModel, sources: tuple[str, ...], tool: str) -> str:
    """modelDescription.xml of `model`; `sources` are the C files of a source FMU (FMI 2
    lists them here, FMI 3 in `build_description`), `tool` the generation tool's name."""
    root = _fmi2(model, sources, tool) if model.fmi == 2 else _fmi3(model, tool)
    return _text(root)


def build_description(model: FmuModel, sources: tuple[str, ...]) -> str:
    """FMI 3's sources/buildDescription.xml: one C99 source file set.

    Example:
        >>> import s2gen
        >>> from s2gen.fmi.model import describe
        >>> m = describe(s2gen.load("double_pendulum"), fmi=3, kind="me", method="vi")
        >>> 'language="C99"' in build_description(m, ("a.c",))
        True
    """
    root = ET.Element("fmiBuildDescription", {"fmiVersion": "3.0"})
    config = ET.SubElement(root, "BuildConfiguration", {"modelIdentifier": model.name})
    files = ET.SubElement(config, "SourceFileSet", {"language": "C99"})
    for name in sources:
        ET.SubElement(files, "SourceFile", {"name": name})
    return _text(root)
