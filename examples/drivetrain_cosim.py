"""Co-simulation of the planetwear FMU in a small drivetrain, driven by fmpy.

Motor (Python) --> sun | planetary FMU, carrier held | ring --shaft (Python)--> vehicle inertia (Python)

Two couplings of the motor to the sun (--coupling):

- torque (torque in, speed out; the default): the motor is a torque source
  with a speed droop, T_m = T_0 + k_m (w_set - w_sun); the FMU takes the
  torque as `sunTorque` and returns the sun's speed (driveMode 0).
- speed (speed in, torque out): the motor is an inertia J_m of its own
  (rotor and coupling) under the same droop law, integrated here; the FMU
  takes its speed as `inputSpeedReference` and drives the sun through its
  input shaft (driveMode 1), returning the shaft's torque
  (`inputShaftTorque`), which acts back on the motor's inertia.

On the output side, both couplings pass the ring's speed and angle to a
compliant shaft (k_s, c_s) into a vehicle-side inertia J_v, whose torque
comes back as `ringTorque` (counter-clockwise positive; the shaft's reaction
on the ring is minus the torque it passes to the vehicle); the road load is
viscous and steps up by 20 % at t_step.

Read every step besides the speeds: the carrier support's `reactionTorque`,
the largest sun–planet mesh force within the step
(`planet[1].sunMeshForceMax`), which a sample at the communication points
alone would alias (the mesh frequency is 1.7 kHz at 3000 rpm), and the
largest force one tooth pair of that mesh carried within the step
(`planet[1].sunToothForceMax`).

The coupling is explicit (inputs held over a step), so the step must be
short against the loops it closes: the motor's droop loop is unstable at
2 ms (torque coupling), the input shaft on the motor's inertia at 1 ms
(speed coupling); 20 µs (the default) to 0.1 ms is clean. docs/FMU.md
("Choosing the communication step") gives the rule and the measurements.

Run:  .venv/bin/python examples/drivetrain_cosim.py [--coupling torque|speed] [--stop 0.05] [--step 2e-5] [--out out/cosim.png]
"""

import argparse
import math
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

REPO = Path(__file__).resolve().parents[1]


def run(fmu_path, stop=0.05, h=2e-5, t_step=0.02, droop=2.0, shaft=(2.0e4, 20.0), coupling="torque",
        motor_inertia=0.02):
    """Rows (t, ω_sun, ω_ring, ω_vehicle, T_motor, T_shaft, F_sun, F_ring,
    T_reaction, F_sun,max over the step, ω_motor) per communication step."""
    if coupling not in ("torque", "speed"):
        raise ValueError(f"coupling = {coupling!r}: allowed are 'torque' and 'speed'")
    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu_path)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="drivetrain")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    if coupling == "speed":
        fmu.setInteger([vr["driveMode"]], [1])
    fmu.exitInitializationMode()

    w_set = 3000 * math.pi / 30          # motor speed set point [rad/s]
    # Droop k_m: the coupling is explicit (torques held over a step), so
    # k_m·h / J must stay well below 1 with J ≈ 1.1e-3 kg m2 of the train
    # reflected to the sun (k_m = 20 gives 1.8 and the co-simulation diverges).
    t0, k_m = 750.0, droop               # motor torque at the set point [N m], droop [N m s/rad]
    ratio = 70 / 34                      # ring/sun tooth ratio (carrier held)
    j_v = 0.5                            # vehicle-side inertia [kg m2]
    k_s, c_s = shaft                     # output shaft stiffness [N m/rad] and damping [N m s/rad]
    w_v = -w_set / ratio                 # vehicle-side speed follows the ring [rad/s]
    w_m = w_set                          # motor speed (speed coupling) [rad/s]
    c_road = t0 * ratio / abs(w_v)       # viscous road load balancing the motor torque [N m s/rad]
    [theta_r] = fmu.getReal([vr["ring.angle"]])
    theta_v = theta_r + t0 * ratio / k_s  # shaft pre-wound to carry the balancing torque

    names = ["sun.speed", "ring.speed", "ring.angle", "planet[1].sunMeshForce", "planet[1].ringMeshForce",
             "reactionTorque", "planet[1].sunMeshForceMax", "inputShaftTorque", "planet[1].sunToothForceMax"]
    refs = [vr[n] for n in names]
    rows = []
    n = int(round(stop / h))
    for k in range(n):
        t = k * h
        w_s, w_r, theta_r, f_s, f_r, t_react, f_s_max, t_in, f_tooth = fmu.getReal(refs)
        t_motor = t0 + k_m * (w_set - (w_m if coupling == "speed" else w_s))
        t_shaft = k_s * (theta_r - theta_v) + c_s * (w_r - w_v)   # torque the shaft passes to the vehicle
        load = c_road * (1.2 if t >= t_step else 1.0) * w_v
        if coupling == "speed":
            # The motor's inertia between its torque and the FMU's input
            # shaft (semi-implicit Euler over the step).
            w_m += h * (t_motor - t_in) / motor_inertia
            fmu.setReal([vr["inputSpeedReference"], vr["ringTorque"]], [w_m, -t_shaft])
        else:
            fmu.setReal([vr["sunTorque"], vr["ringTorque"]], [t_motor, -t_shaft])
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        # Vehicle side: semi-implicit Euler over the same step.
        w_v += h * (t_shaft - load) / j_v
        theta_v += h * w_v
        rows.append((t + h, w_s, w_r, w_v, t_motor, t_shaft, f_s, f_r, t_react, f_s_max, w_m, f_tooth))
    fmu.terminate()
    fmu.freeInstance()
    return np.array(rows)


def plot(rows, out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = rows[:, 0] * 1e3
    fig, ax = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    ax[0].plot(t, rows[:, 1] * 30 / math.pi, label="sun (motor)")
    ax[0].plot(t, -rows[:, 2] * 30 / math.pi, label="ring (−)")
    ax[0].plot(t, -rows[:, 3] * 30 / math.pi, label="vehicle side (−)")
    ax[0].set_ylabel("speed (rpm)")
    ax[1].plot(t, rows[:, 4], label="motor torque on the sun")
    ax[1].plot(t, rows[:, 5], label="output shaft torque")
    ax[1].set_ylabel("torque (N·m)")
    ax[1].plot(t, rows[:, 8], label="carrier reaction torque")
    ax[2].plot(t, rows[:, 9] / 30, label="planet 1 sun-planet, largest within each step", lw=0.8)
    ax[2].plot(t, rows[:, 11] / 30, label="planet 1 sun-planet, largest tooth-pair force within each step", lw=0.8)
    ax[2].plot(t, rows[:, 6] / 30, label="planet 1 sun-planet")
    ax[2].plot(t, rows[:, 7] / 30, label="planet 1 ring-planet")
    ax[2].set_ylabel("mesh force (N/mm)")
    ax[2].set_xlabel("time (ms)")
    for a in ax:
        a.legend(loc="best")
        a.grid(True)
    fig.suptitle("planetwear FMU in a drivetrain co-simulation (road load +20 % at 20 ms)")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp" + out.suffix)
    fig.savefig(tmp, dpi=100)
    tmp.replace(out)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fmu", default=str(REPO / "fmu" / "planetwear.fmu"))
    p.add_argument("--stop", type=float, default=0.05)
    p.add_argument("--step", type=float, default=2e-5, help="communication step [s]")
    p.add_argument("--coupling", choices=("torque", "speed"), default="torque")
    p.add_argument("--out", default=str(REPO / "out" / "cosim.png"))
    a = p.parse_args()
    rows = run(a.fmu, stop=a.stop, h=a.step, coupling=a.coupling)
    plot(rows, Path(a.out))
    last = rows[len(rows) // 2:]
    print(f"{a.coupling} coupling, step {a.step:g} s: {len(rows)} steps; final speeds: sun "
          f"{rows[-1, 1] * 30 / math.pi:.1f} rpm, vehicle side {rows[-1, 3] * 30 / math.pi:.1f} rpm; second half: "
          f"mean sun mesh force {last[:, 6].mean() / 30:.1f} N/mm, largest within a step "
          f"{last[:, 9].max() / 30:.1f} N/mm (at the communication points {last[:, 6].max() / 30:.1f}), "
          f"largest tooth-pair force {last[:, 11].max() / 30:.1f} N/mm, "
          f"mean carrier reaction torque {last[:, 8].mean():.1f} N·m; wrote {a.out}")


if __name__ == "__main__":
    main()
