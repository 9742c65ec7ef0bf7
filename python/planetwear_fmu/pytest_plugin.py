"""pytest plugin of the regression-test kit (planetwear_fmu.regression).

Registered through the ``pytest11`` entry point of the planetwear-fmu
package, so installing the package makes the fixtures available in any
pytest run:

- ``planetwear_fmu_path``: the FMU under test, from ``--planetwear-fmu PATH``,
  the ini option ``planetwear_fmu`` or the environment variable
  ``PLANETWEAR_FMU`` (override the fixture in a conftest.py to choose it in
  code);
- ``planetwear_reference``: a ``ReferenceKit`` with the references shipped in
  that FMU (refused unless they belong to it) and
  ``assert_reproduces(case, measured)``.

    def test_my_drivetrain(planetwear_reference):
        kit = planetwear_reference
        case = kit.case("kappa-0/3000rpm")
        measured = my_drivetrain_run(kit.fmu, kit.parameters(case), kit.inputs(case), kit.duration(case))
        kit.assert_reproduces(case, measured)   # names case, quantity, value, reference, tolerance

Layer 4 (front end): this module owns the fixtures and ``ReferenceKit``. Of
the package it imports only ``regression`` (below it); no module of the
package imports it (pytest loads it through the entry point).
"""

import os
from pathlib import Path

import pytest

from . import regression


def pytest_addoption(parser):
    group = parser.getgroup("planetwear", "planetwear FMU regression references")
    group.addoption("--planetwear-fmu", dest="planetwear_fmu", default=None, metavar="PATH",
                    help="the planetwear FMU (.fmu or unpacked directory) whose shipped references "
                         "the planetwear_reference fixture uses")
    parser.addini("planetwear_fmu", "the planetwear FMU for the planetwear_reference fixture", default="")


class ReferenceKit:
    """The references of one FMU, and the assertion against them."""

    def __init__(self, fmu):
        self.fmu = Path(fmu)
        self.references = regression.load_references(self.fmu)
        self.references.check_fmu(self.fmu)

    @property
    def cases(self):
        return self.references.cases

    @property
    def protocol(self):
        return self.references.protocol

    def case(self, name):
        return self.references.case(name)

    def parameters(self, case):
        return self.references.parameters(case)

    def inputs(self, case):
        return self.references.inputs(case)

    def duration(self, case):
        return self.references.duration(case)

    def run(self, case, **kwargs):
        """The FMU alone through the protocol (regression.run_reference_case)."""
        return regression.run_reference_case(self.fmu, case, references=self.references, **kwargs)

    def compare(self, case, measured):
        return regression.compare(self.references._case(case), measured)

    def assert_reproduces(self, case, measured):
        """Raises AssertionError naming the case, and each quantity outside
        its tolerance with value, reference and tolerance; returns the
        Comparison (its report() is a table) when all agree."""
        return self.compare(case, measured).assert_ok()


@pytest.fixture(scope="session")
def planetwear_fmu_path(request):
    path = (request.config.getoption("planetwear_fmu") or request.config.getini("planetwear_fmu")
            or os.environ.get("PLANETWEAR_FMU"))
    if not path:
        raise pytest.UsageError("the planetwear_reference fixture needs the FMU under test: pass "
                                "--planetwear-fmu PATH, set the ini option planetwear_fmu or the environment "
                                "variable PLANETWEAR_FMU, or override the planetwear_fmu_path fixture")
    return Path(path)


@pytest.fixture(scope="session")
def planetwear_reference(planetwear_fmu_path):
    return ReferenceKit(planetwear_fmu_path)
