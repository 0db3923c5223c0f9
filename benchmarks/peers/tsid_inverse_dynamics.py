"""TSID on the inverse-dynamics scene of benchmarks/suites/inverse_dynamics.py (.venv-peers/tsid).

G1 standing on two 6-D contacts (4 corner points each, friction cone, min/max force), torque
bounds, tasks CoM + both hands + posture; the loop integrates TSID's accelerations (as in its
demos). A step is timed from computeProblemData to the torques.
"""

import json
import sys
import time

import numpy as np


def main():
    spec = json.load(open(sys.argv[1]))
    import glob
    import os

    import pinocchio as pin
    import tsid

    if not hasattr(tsid, "RobotWrapper"):
        # the tsid 1.7.1 wheel nests its extension one directory down (tsid/tsid_pywrap*.so
        # next to an inner tsid/ package), so `import tsid` finds an empty namespace package
        for path in tsid.__path__:
            sys.path.insert(0, path)
        import tsid_pywrap as tsid  # type: ignore[import-not-found,no-redef]

    steps, dt = spec["steps"], spec["dt"]
    # Every object handed to TSID (contacts, tasks, references) is kept alive: the formulation
    # holds C++ references to them, and a contact freed when the loop variable moved on made
    # the 1.7.1 wheel abort ("pure virtual method called") in computeProblemData.
    alive: list = []

    def keep(obj):  # type: ignore[no-untyped-def]
        alive.append(obj)
        return obj

    def sample(trajectory):  # type: ignore[no-untyped-def]
        return keep(keep(trajectory).computeNext())

    pattern = os.path.join(sys.prefix, "**/share/example-robot-data/robots")
    share = glob.glob(pattern, recursive=True)[0]
    urdf = os.path.join(share, "g1_description/urdf/g1_29dof_rev_1_0.urdf")
    model = pin.buildModelFromUrdf(urdf, pin.JointModelFreeFlyer())
    robot = tsid.RobotWrapper(model, tsid.FLOATING_BASE_SYSTEM, False)
    q = np.array(spec["q0"])
    v = np.zeros(robot.nv)
    formulation = tsid.InverseDynamicsFormulationAccForce("tsid", robot, False)
    formulation.computeProblemData(0.0, q, v)
    data = formulation.data()
    lx, ly = 0.1, 0.03
    points = np.array([[lx, lx, -lx, -lx], [ly, -ly, ly, -ly], [0.0, 0.0, 0.0, 0.0]])
    for name in ("left_ankle_roll_link", "right_ankle_roll_link"):
        normal = np.array([0, 0, 1.0])
        contact = keep(tsid.Contact6d(name, robot, name, points, normal, 0.7, 1.0, 1000.0))
        contact.setKp(np.zeros(6))
        contact.setKd(20.0 * np.ones(6))
        contact.setReference(keep(robot.framePosition(data, model.getFrameId(name))))
        formulation.addRigidContact(contact, 1e-5, 1.0, 1)
    com = tsid.TaskComEquality("com", robot)
    com.setKp(50.0 * np.ones(3))
    com.setKd(2.0 * np.sqrt(50.0) * np.ones(3))
    formulation.addMotionTask(com, 1.0, 1, 0.0)
    com_ref = robot.com(data).copy()
    com.setReference(sample(tsid.TrajectoryEuclidianConstant("com", com_ref)))
    for name in ("left_rubber_hand", "right_rubber_hand"):
        task = keep(tsid.TaskSE3Equality(name, robot, name))
        task.setKp(50.0 * np.ones(6))
        task.setKd(2.0 * np.sqrt(50.0) * np.ones(6))
        formulation.addMotionTask(task, 0.1, 1, 0.0)  # our weights: hands 0.1
        ref = robot.framePosition(data, model.getFrameId(name))
        task.setReference(sample(tsid.TrajectorySE3Constant(name, keep(ref))))
    posture = tsid.TaskJointPosture("posture", robot)
    posture.setKp(30.0 * np.ones(robot.nv - 6))
    posture.setKd(2.0 * np.sqrt(30.0) * np.ones(robot.nv - 6))
    formulation.addMotionTask(posture, 1e-2, 1, 0.0)  # posture 1e-2
    posture.setReference(sample(tsid.TrajectoryEuclidianConstant("posture", keep(q[7:].copy()))))
    bounds = tsid.TaskActuationBounds("torques", robot)
    tau_max = model.effortLimit[6:]
    bounds.setBounds(-tau_max, tau_max)
    formulation.addActuationTask(bounds, 1.0, 0, 0.0)
    check_data = model.createData()  # the CoM error, outside the timed region
    solver = tsid.SolverHQuadProgFast("qp")
    solver.resize(formulation.nVar, formulation.nEq, formulation.nIn)
    times, failed, com_errors = [], 0, []
    t = 0.0
    for _ in range(steps):
        com_k = com_ref + np.array([0.0, 0.04 * np.sin(np.pi * t), 0.0])
        com_traj = tsid.TrajectoryEuclidianConstant("com", com_k)
        com_sample = com_traj.computeNext()
        com.setReference(com_sample)
        com_errors.append(float(np.linalg.norm(pin.centerOfMass(model, check_data, q) - com_k)))
        t0 = time.perf_counter()
        problem = formulation.computeProblemData(t, q, v)
        sol = solver.solve(problem)
        tau = formulation.getActuatorForces(sol)
        dv = formulation.getAccelerations(sol)
        times.append(time.perf_counter() - t0)
        if sol.status != 0:
            failed += 1
        v = v + dt * dv
        q = pin.integrate(model, q, dt * v)
        t += dt
    print(
        json.dumps(
            {
                "times": times,
                "failed_steps": failed,
                "variables": formulation.nVar,
                "note": f"{formulation.nVar} variables, HQuadProgFast",
                "final_tau_norm": float(np.linalg.norm(tau)),
                "com_errors": com_errors,
            }
        )
    )


if __name__ == "__main__":
    main()
