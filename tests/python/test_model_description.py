"""fmpy's validation of the generated modelDescription.xml (schema, names,
model structure, start values, causality/variability, units)."""

import shutil
from pathlib import Path

from fmpy.validation import validate_fmu

REPO = Path(__file__).resolve().parents[2]


def test_fmpy_validates_the_model_description(tmp_path):
    shutil.copy(REPO / "fmu" / "modelDescription.xml", tmp_path / "modelDescription.xml")
    problems = validate_fmu(str(tmp_path))
    print(f"fmpy validate: {len(problems)} problems", *problems, sep="\n")
    assert problems == []
