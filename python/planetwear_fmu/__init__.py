"""Python side of planetwear, for users of the planetwear FMU through fmpy.

Installed into the project's virtual environment by scripts/setup.sh
(`pip install -e python`).

The modules form layers; a module imports only modules of lower layers
(lazy imports inside functions included), so there is no import circle.
tests/python/test_package_layers.py holds the list and checks it:

  0. `files` (write_atomic, sha256_file), `extras` (which optional extra a
     command needs) and this `__init__`, which imports
     nothing: importing any module of the package runs it first, so it
     must not pull in the others;
  1. `campaign_file`: the campaign file and the worn-profile state's format;
     `duty`: the load duty the FMU gives (`dutyCycle`) as a duty-cycle file;
  2. FMU access and results: `fmu_check` (the FMU's verdict and
     `load_campaign`, the full check), `sweep` (one task), `plots`,
     `regression` (the regression-test kit, apart from the campaigns);
  3. `runner`: a campaign on Dask;
  4. front ends: `loop`, `drive_cycle`, `bench`, `pytest_plugin`;
  5. `campaign`: the command line (`python -m planetwear_fmu.campaign`,
     the `planetwear-campaign` script).
"""
