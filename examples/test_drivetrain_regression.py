"""A pytest file a user writes to pin a drivetrain model that embeds the
planetwear FMU: the model, run with its own driver at a reference case's
operating point, must reproduce the references shipped in the FMU
(docs/REGRESSION.md).

The fixture `planetwear_reference` comes with the planetwear-fmu package
(`pip install -e python`; a pytest plugin); it needs the FMU under test:

    .venv/bin/python -m pytest examples/test_drivetrain_regression.py --planetwear-fmu fmu/planetwear.fmu

`Drivetrain` stands for the user's own model: a motor on the sun, a
dynamometer on the ring and the planetary FMU between them, exchanged every
20 µs (explicit coupling, as in examples/drivetrain_cosim.py). In its test
mode the motor and the dynamometer hold the case's torques; the FMU starts
at the case's speed with the protocol's parameters.
"""

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave


class Drivetrain:
    """The user's drivetrain model with the planetwear FMU embedded."""

    def __init__(self, fmu_path, fmu_parameters, step=2e-5):
        md = read_model_description(str(fmu_path))
        self.variables = {v.name: v for v in md.modelVariables}
        self.step = step
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu_path)),
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName="drivetrain")
        self.fmu.instantiate(loggingOn=False)
        self.fmu.setupExperiment(startTime=0.0)
        for name, value in fmu_parameters.items():
            self._set(name, value)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.time = 0.0
        self.torques = {}

    def _set(self, name, value):
        v = self.variables[name]
        if v.type == "Real":
            self.fmu.setReal([v.valueReference], [float(value)])
        elif v.type == "Integer":
            self.fmu.setInteger([v.valueReference], [int(value)])
        else:
            self.fmu.setString([v.valueReference], [str(value)])

    def hold(self, sunTorque, ringTorque, carrierTorque):
        """Test mode: the motor and the dynamometer hold these torques [N·m]."""
        self.torques = {"sunTorque": sunTorque, "ringTorque": ringTorque, "carrierTorque": carrierTorque}

    def run(self, stop):
        """Co-simulates to `stop` [s] with the model's own communication step."""
        n = int(round(stop / self.step))
        for k in range(n):
            for name, value in self.torques.items():
                self._set(name, value)
            t = k * self.step
            h = stop - t if k == n - 1 else self.step
            self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        self.time = stop

    def window_outputs(self, names):
        refs = [self.variables[n].valueReference for n in names]
        return dict(zip(names, self.fmu.getReal(refs)))

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


@pytest.mark.parametrize("name", ["kappa-0/3000rpm", "kappa-6/5000rpm"])
def test_my_drivetrain_reproduces_the_planetwear_reference(planetwear_reference, name):
    kit = planetwear_reference
    case = kit.case(name)
    model = Drivetrain(kit.fmu, kit.parameters(case))
    try:
        model.hold(**kit.inputs(case))
        model.run(kit.duration(case))
        measured = model.window_outputs(list(case.values))
    finally:
        model.close()
    # Raises AssertionError naming the case and each quantity outside its
    # tolerance (value, reference, tolerance); prints the table otherwise.
    print(kit.assert_reproduces(case, measured).report())
