"""Werner 2019's 15 controller-structure x feedback combinations (Sec. 3.2, Table 1; digest 3.3-3.4):
the general closed loop (frequency-domain law ``G(s) P T^T``) against the paper's embedding of the
gains into M, D, C (eqs. 24, 29, 37 and their renamings), against the state space with controller
states where the embedding does not exist, and the paper's equivalences (Eq. 60)."""
import math

import numpy as np
import pytest

from rotor_avc.closed_loop.loop import ClosedLoop
from rotor_avc.closed_loop.frf import unbalance_frf
from rotor_avc.control.spec import (i_controller, p_controller, pd_controller, pi_controller,
                                    pid_controller)
from rotor_avc.errors import ModelError
from rotor_avc.machine import load_machine

B = 0.53
SPEEDS = np.arange(300.0, 4501.0, 50.0) * math.pi / 30
# illustrative gains per feedback kind (SI); the right foot gets 1.3 x the left's
GAINS = {"displacement": {"kp": 5e8, "ki": 1e9, "kd": 2e5},
         "velocity": {"kp": 5e5, "ki": 2e8, "kd": 2e3},
         "acceleration": {"kp": 3e3, "ki": 4e5, "kd": 10.0}}
RIGHT = 1.3
# Table 1: where the gains go (M, D, C) or None ("--": not of the form of eq. 59)
TABLE = {
    ("P", "displacement"): {"C": "kp"},
    ("PD", "displacement"): {"D": "kd", "C": "kp"},
    ("I", "displacement"): None, ("PI", "displacement"): None, ("PID", "displacement"): None,
    ("P", "velocity"): {"D": "kp"},
    ("PD", "velocity"): {"M": "kd", "D": "kp"},
    ("I", "velocity"): {"C": "ki"},
    ("PI", "velocity"): {"D": "kp", "C": "ki"},
    ("PID", "velocity"): {"M": "kd", "D": "kp", "C": "ki"},
    ("P", "acceleration"): {"M": "kp"},
    ("PD", "acceleration"): None,
    ("I", "acceleration"): {"D": "ki"},
    ("PI", "acceleration"): {"M": "kp", "D": "ki"},
    ("PID", "acceleration"): None,
}
FACTORY = {"P": lambda g, fb: p_controller(g["kp"], fb), "I": lambda g, fb: i_controller(g["ki"], fb),
           "PI": lambda g, fb: pi_controller(g["kp"], g["ki"], fb),
           "PD": lambda g, fb: pd_controller(g["kp"], g["kd"], fb),
           "PID": lambda g, fb: pid_controller(g["kp"], g["ki"], g["kd"], fb)}


@pytest.fixture(scope="module")
def plant():
    return load_machine("sleeve_bearing_motor").plant


def loop_for(plant, structure, feedback, scale=1.0):
    gains = {k: scale * v for k, v in GAINS[feedback].items()}
    return ClosedLoop(plant, {"L": FACTORY[structure](gains, feedback),
                              "R": FACTORY[structure]({k: RIGHT * v for k, v in gains.items()},
                                                      feedback)})


def increment(K_L, K_R):
    """The eight entries each P T^T pair adds (digest 3.3; eqs. 24, 29, 37), 0-based."""
    X = np.zeros((13, 13), dtype=np.result_type(K_L, K_R, float))
    X[0, 0] = K_L + K_R
    X[0, 4] = X[4, 0] = B * (K_R - K_L)
    X[4, 4] = B**2 * (K_L + K_R)
    X[7, 0], X[7, 4] = -K_L, B * K_L
    X[8, 0], X[8, 4] = -K_R, -B * K_R
    return X


def paper_embedding(plant, speed, where, feedback):
    w_F = plant.forced_damping_frequency(speed)
    mats = {"M": plant.mass.copy(), "D": plant.damping(speed, w_F), "C": plant.stiffness_at(speed, w_F)}
    for matrix, gain in where.items():
        K = GAINS[feedback][gain]
        mats[matrix] = mats[matrix] + increment(K, RIGHT * K)
    return mats["M"], mats["D"], mats["C"]


def responses(frf):
    return np.array([frf.responses[k] for k in sorted(frf.responses)])


@pytest.mark.parametrize("structure,feedback", [k for k, v in TABLE.items() if v is not None])
def test_embedding_matches_general_loop(plant, structure, feedback):
    loop = loop_for(plant, structure, feedback)
    frf = unbalance_frf(loop, SPEEDS, ["bent_rotor"])
    F = plant.excitation("bent_rotor").phasor(SPEEDS)
    names, rows, orders = plant.output_rows()
    for k, speed in enumerate(SPEEDS[::8]):
        M, D, C = paper_embedding(plant, speed, TABLE[(structure, feedback)], feedback)
        got = loop.embedded_matrices(speed, plant.forced_damping_frequency(speed))
        for g, want in zip(got, (M, D, C)):
            assert np.allclose(g, want, rtol=0, atol=1e-9 * np.abs(want).max())
    for k, speed in enumerate(SPEEDS):
        M, D, C = paper_embedding(plant, speed, TABLE[(structure, feedback)], feedback)
        q = np.linalg.solve(-speed**2 * M + 1j * speed * D + C, F[k])       # eq. 65
        for name, row, order in zip(names, rows, orders):
            want = (1j * speed) ** order * row @ q
            assert abs(frf.responses[f"{name}_bent_rotor"][k] - want) <= 1e-9 * abs(want) + 1e-300


@pytest.mark.parametrize("structure", ["I", "PI", "PID"])
def test_integral_on_displacement_needs_states(plant, structure):
    """Table 1's "--" displacement cells: no embedding, but the frequency-domain loop equals the
    state space with one integrator state per foot (digest 3.5 step 2)."""
    loop = loop_for(plant, structure, "displacement")
    with pytest.raises(ModelError, match="cannot be embedded"):
        loop.embedded_matrices(SPEEDS[0], SPEEDS[0])
    frf = unbalance_frf(loop, SPEEDS, ["bent_rotor"])
    F = plant.excitation("bent_rotor").phasor(SPEEDS)
    n = plant.n
    rows = {o.name: o.row for o in plant.outputs}
    for k, speed in enumerate(SPEEDS):
        A, Bm = loop.state_space(speed, plant.forced_damping_frequency(speed))
        assert A.shape[0] == 2 * n + 2
        x = np.linalg.solve(1j * speed * np.eye(A.shape[0]) - A, Bm @ F[k])
        for name, row in rows.items():
            want = row @ x[n:2 * n]                       # velocity outputs: the q' states
            assert abs(frf.responses[f"{name}_bent_rotor"][k] - want) <= 1e-9 * abs(want)


@pytest.mark.parametrize("structure", ["PD", "PID"])
def test_derivative_on_acceleration_is_frequency_domain_only(plant, structure):
    """Table 1's "--" acceleration cells (a force on the jerk): refused by the embedding and the
    state space, while the frequency-domain law ``G(j Omega) P T^T`` (eqs. 74-77) still holds."""
    loop = loop_for(plant, structure, "acceleration")
    for call in (lambda: loop.embedded_matrices(SPEEDS[0], SPEEDS[0]),
                 lambda: loop.state_space(SPEEDS[0], SPEEDS[0])):
        with pytest.raises(ModelError, match="jerk"):
            call()
    g = GAINS["acceleration"]
    speed = SPEEDS[20]
    s = 1j * speed
    w_F = plant.forced_damping_frequency(speed)
    G = g["kp"] * s**2 + g["kd"] * s**3 + (g["ki"] * s if structure == "PID" else 0.0)
    Z = -speed**2 * plant.mass + s * plant.damping(speed, w_F) + plant.stiffness_at(speed, w_F)
    Z = Z + increment(G, RIGHT * G)
    q = np.linalg.solve(Z, plant.excitation("bent_rotor").phasor(speed))
    frf = unbalance_frf(loop, [speed], ["bent_rotor"])
    assert frf.responses["bearing_vz_bent_rotor"][0] == pytest.approx(s * q[6], rel=1e-9)
    assert frf.responses["actuator_L_fz_bent_rotor"][0] == pytest.approx(-G * (q[0] - B * q[4]),
                                                                         rel=1e-9)


@pytest.mark.parametrize("a,b", [(("P", "displacement"), ("I", "velocity")),
                                 (("P", "velocity"), ("I", "acceleration")),
                                 (("PD", "displacement"), ("PI", "velocity"))])
def test_equal_gains_give_equal_equations(plant, a, b):
    """Eq. (60) and the text around it: e.g. P on displacement == I on velocity at equal gains."""
    ga, gb = dict(GAINS[a[1]]), dict(GAINS[b[1]])
    if b == ("I", "velocity"):
        gb["ki"] = ga["kp"]
    elif b == ("I", "acceleration"):
        gb["ki"] = ga["kp"]
    else:                                          # PD on displacement == PI on velocity
        gb["kp"], gb["ki"] = ga["kd"], ga["kp"]
    la = ClosedLoop(plant, {i: FACTORY[a[0]](ga, a[1]) for i in "LR"})
    lb = ClosedLoop(plant, {i: FACTORY[b[0]](gb, b[1]) for i in "LR"})
    fa, fb = (responses(unbalance_frf(x, SPEEDS, ["bent_rotor"])) for x in (la, lb))
    assert np.allclose(fa, fb, rtol=1e-9, atol=0)
