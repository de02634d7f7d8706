"""3-DOF devices in the loop (issue 12): the simulator, the renderer and the passivity
controller in 3-D, the decoupled fast path, and the 3-DOF presets."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

import haptex as hx
from haptex.core import _ext
from haptex.operators import ConstantForce, ElasticBand, KinematicPath, ScanningHand

A, L, K0 = 0.8e-3, 1e-3, 2000.0  # the paper's Section V-A sinusoid and stiffness
SIM = sys.modules["haptex.simulate"]


def _hand(d, **kw):
    return ScanningHand(300.0, 1.0, velocity=0.01, depth=1e-3, dimension=d, **kw)


@pytest.mark.parametrize("letter", list("WABCDEFG"))
def test_3d_simulation_of_an_extruded_profile_is_the_2d_simulation(letter):
    # DESIGN.md: a profile is the 1-D case of a surface; the 3-D loop over Extruded(h) with the
    # motion in the plane y = 0 must reproduce the 2-D loop over h (same exact discretisation,
    # per axis, the y axis carrying nothing)
    tex = hx.Sinusoid(A, L)
    kw = {"stick_deflection": 0.5 * 1e-3} if letter == "F" else {}
    a2 = hx.algorithm(letter, None if letter == "W" else tex, K0, **kw)
    a3 = hx.algorithm(letter, hx.Flat(dimension=2) if letter == "W" else hx.Extruded(tex), K0, **kw)
    dev2 = hx.Device.pantograph(joint_damping=4e-3)
    xz = np.ix_([0, 2], [0, 2])
    M3, B3, Bo3 = np.diag([0.0, 0.05, 0.0]), np.diag([0.0, 0.5, 0.0]), np.diag([0.0, 0.5, 0.0])
    M3[xz], B3[xz], Bo3[xz] = dev2.mass, dev2.damping, dev2.damping_outside
    dev3 = hx.Device(mass=M3, damping=B3, damping_outside=Bo3, period=dev2.period,
                     position_resolution=dev2.position_resolution)
    r2 = hx.simulate(a2, dev2, ScanningHand(300.0, 1.0, velocity=0.01, depth=1e-3), 0.1)
    r3 = hx.simulate(a3, dev3, _hand(3), 0.1)
    assert r3.dimension == 3 and r3.position.shape == (r2.position.shape[0], 3)
    np.testing.assert_allclose(r3.position[:, [0, 2]], r2.position, rtol=0, atol=1e-15)
    assert np.all(r3.position[:, 1] == 0.0) and np.all(r3.energy_y == 0.0)
    for key in ("energy_x", "energy_z", "damping_energy", "operator_work"):
        assert r3.totals[key] == pytest.approx(r2.totals[key], rel=1e-12, abs=1e-18)
    assert r3.oscillating == r2.oscillating


@pytest.mark.parametrize("letter", list("ABCDEFG"))
def test_the_compiled_3d_force_is_the_vectorised_field(letter):
    # the C core's tick (the simulator's and the renderer's) against Algorithm.force over the
    # egg-crate and a sampled height map, at random positions inside and outside
    rng = np.random.default_rng(3)
    x, y = np.meshgrid(np.linspace(0, 2e-3, 24), np.linspace(0, 2e-3, 24), indexing="ij")
    sampled = hx.SampledSurface(x[:, 0], y[0], 0.3e-3 * np.sin(2 * np.pi * x / 1e-3) * np.cos(2 * np.pi * y / 1.5e-3))
    for tex in (hx.SumOfGratings.egg_crate(A, L), sampled):
        alg = hx.algorithm(letter, tex, K0)
        r = hx.Renderer(alg)
        p = np.column_stack([rng.uniform(0.2e-3, 1.8e-3, 60), rng.uniform(0.2e-3, 1.8e-3, 60),
                             rng.uniform(-1.2e-3, 0.9e-3, 60)])
        for pi in p:
            r.reset()  # F from a fresh contact: zero deflection
            got = r.step(pi.tolist())
            want = alg.force(pi)
            np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9 * K0 * 1e-3)


def test_the_3d_energy_balance_closes_over_a_million_samples():
    # issue 12: energy balance <= 1e-9 relative over 10^6 samples, exact ZOH in 3-D (a scanning
    # hand dragging the handle over the egg-crate with algorithm A, general path, and a
    # constant push, fast path)
    alg = hx.algorithm("A", hx.SumOfGratings.egg_crate(A, L), K0)
    dev = hx.Device.point_mass(dimension=3)
    for op in (_hand(3), ConstantForce([0.2, 0.1, -1.0])):
        r = hx.simulate(alg, dev, op, 100.0, record_every=10_000)
        assert r.time.size == 100 and r.energy_balance_error <= 1e-9


@pytest.mark.parametrize("d", [2, 3])
def test_the_fast_path_is_the_general_path(monkeypatch, d):
    # the decoupled per-axis closed forms (a diagonal device pushed by a constant force) give
    # the same run as the 10x10 (15x15) augmented transition, to round-off; with a delay,
    # quantisation, a force limit and Coulomb friction
    tex = hx.Sinusoid(A, L) if d == 2 else hx.SumOfGratings.egg_crate(A, L)
    alg = hx.algorithm("B", tex, K0)
    dev = hx.Device(mass=np.diag([0.1, 0.12, 0.08][:d]), damping=np.diag([0.5, 0.4, 0.6][:d]),
                    damping_outside=np.diag([0.1, 0.2, 0.3][:d]), period=1e-4, delay=1, position_resolution=1e-6,
                    max_force=1.5, coulomb_friction=0.05)
    push = ConstantForce([0.3, -1.2] if d == 2 else [0.3, 0.2, -1.2])
    assert SIM._fast_coefficients(dev, push).shape == (2, d, _ext.N_FAST)
    fast = hx.simulate(alg, dev, push, 0.3)
    monkeypatch.setattr(SIM, "_fast_coefficients", lambda device, op: np.zeros((0, device.dimension, _ext.N_FAST)))
    general = hx.simulate(alg, dev, push, 0.3)
    np.testing.assert_allclose(fast.position, general.position, rtol=0, atol=1e-12)
    for key in ("energy_x", "energy_z", "damping_energy", "operator_work", "friction_energy"):
        assert fast.totals[key] == pytest.approx(general.totals[key], rel=1e-9, abs=1e-15)
    assert fast.energy_balance_error < 1e-10 and general.energy_balance_error < 1e-10


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("letter", ["W", "A", "B", "D"])
def test_the_lean_loop_is_the_fast_path_without_its_machinery(monkeypatch, d, letter):
    # the lean loop (no delay, quantisation, saturation, friction or controller) against the general one on a
    # device whose only difference is a force limit it never reaches: the same arithmetic in the
    # same order, so every recorded sample and every total is equal, not merely close (both are
    # the C core's loops, each instantiated per letter).
    tex = hx.Sinusoid(A, L) if d == 2 else hx.SumOfGratings.egg_crate(A, L)
    alg = hx.algorithm(letter, (None if d == 2 else hx.Flat(dimension=2)) if letter == "W" else tex, K0)
    dev = hx.Device(mass=np.diag([0.1, 0.12, 0.08][:d]), damping=np.diag([0.5, 0.4, 0.6][:d]),
                    damping_outside=np.diag([0.1, 0.2, 0.3][:d]), period=1e-4)
    push = ConstantForce([0.3, -1.2] if d == 2 else [0.3, 0.2, -1.2])
    calls = []
    core_lean = SIM._core_lean  # the C core's lean loop
    monkeypatch.setattr(SIM, "_core_lean", lambda *a, **k: calls.append(1) or core_lean(*a, **k))
    duration = 0.05 if letter == "D" else 0.3
    fast = hx.simulate(alg, dev, push, duration)
    assert calls == [1]
    general = hx.simulate(alg, dev.replace(max_force=1e6), push, duration)
    assert calls == [1] and general.saturations == 0
    for name in ("position", "velocity", "force", "energy_x", "energy_z", "damping_energy", "operator_work",
                 "kinetic_energy"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(general, name), err_msg=name)
    assert fast.totals == general.totals and fast.max_penetration == general.max_penetration
    assert fast.oscillation == general.oscillation
    # and in a batch: the lean batch is the general batch run for run
    b_fast = hx.simulate_batch(alg, dev, push, duration, stiffness=[K0, 2 * K0])
    b_gen = hx.simulate_batch(alg, dev.replace(max_force=1e6), push, duration, stiffness=[K0, 2 * K0])
    for name in ("energy_x", "energy_z", "damping_energy", "operator_work", "kinetic_energy", "amplitude",
                 "frequency", "max_penetration", "oscillating"):
        np.testing.assert_array_equal(getattr(b_fast, name), getattr(b_gen, name), err_msg=name)


def test_a_3d_wall_settles_where_the_push_balances_the_spring():
    # closed form: W in 3-D under a constant push f settles at z = -f_z / kappa_0; the lateral
    # push slides the handle at the terminal velocity f_x / b of the viscous damping
    alg = hx.algorithm("W", hx.Flat(dimension=2), K0)
    dev = hx.Device.point_mass(mass=0.1, damping=0.5, dimension=3)
    r = hx.simulate(alg, dev, ConstantForce([0.05, 0.0, -1.0]), 8.0)  # 20 decay times 2m/b
    assert r.position[-1, 2] == pytest.approx(-1.0 / K0, rel=1e-6)
    assert r.velocity[-1, 0] == pytest.approx(0.05 / 0.5, rel=1e-6)
    assert abs(r.position[-1, 1]) == 0.0


def test_batches_in_3d_sweep_the_y_push_and_start():
    # the energy a constant lateral push f_y puts in over a run is f_y * (y_end - y_0); at rest
    # in y (f_y = 0) no work is done along y
    alg = hx.algorithm("A", hx.SumOfGratings.egg_crate(A, L), K0)
    dev = hx.Device.point_mass(dimension=3)
    b = hx.simulate_batch(alg, dev, ConstantForce([0.0, 0.0, -1.0]), 0.05, push_y=[0.0, 0.1], initial_y=[0.0, 2e-4],
                          record=True)
    assert b.energy_y is not None and b.energy_balance_error.max() < 1e-10
    run0, run1 = b.runs
    assert np.all(run0.position[:, 1] == 0.0)
    assert run1.position[0, 1] > 2e-4  # started at y = 0.2 mm and pushed along +y
    with pytest.raises(hx.ParameterError, match="initial_y is not allowed in the plane"):
        hx.simulate_batch(hx.algorithm("A", hx.Sinusoid(A, L), K0), hx.Device.point_mass(),
                          ConstantForce([0.0, -1.0]), 0.01, initial_y=[0.0])


def test_operators_take_three_coordinates():
    assert ConstantForce([0, 0, -1.0]).dimension == 3
    band = ElasticBand(100.0, [0.0, 0.0, -0.03])
    assert band.dimension == 3 and band.stiffness.shape == (3, 3)
    path = KinematicPath([[0, 0, 0], [1e-3, 1e-3, -1e-3]], 1e-3)
    assert path.dimension == 3 and path.setpoint_times[-1] == pytest.approx(math.sqrt(3))
    hand = ScanningHand(np.eye(3) * 300, 1.0, velocity=0.01, depth=1e-3)
    assert hand.dimension == 3 and hand.setpoint_points[0].tolist() == [0.0, 0.0, -1e-3]
    for call, message in [
        (lambda: ConstantForce([0, 0, 0, -1.0]), "force = .* two .* or three .* finite numbers"),
        (lambda: ScanningHand(np.eye(2), 1.0, velocity=0.01, dimension=3), "stiffness = .* 3x3 matrix"),
        (lambda: hx.simulate(hx.algorithm("A", hx.SumOfGratings.egg_crate(A, L), K0), hx.Device.point_mass(dimension=3),
                             ConstantForce([0.0, -1.0]), 0.01), "operator of dimension 2 is not allowed"),
        (lambda: hx.Device(mass=np.eye(2), damping=np.eye(3), period=1e-4), "damping = .* 2x2"),
    ]:
        with pytest.raises(hx.ParameterError, match=message):
            call()


# -- renderer in 3-D ---------------------------------------------------------------------------
@pytest.mark.parametrize("letter", list("WABCDEG"))
def test_the_3d_renderer_commands_the_field_and_faults_on_bad_positions(letter):
    tex = hx.Flat(dimension=2) if letter == "W" else hx.SumOfGratings.egg_crate(A, L)
    alg = hx.algorithm(letter, tex, K0)
    r = hx.Renderer(alg, max_force=5.0)
    rng = np.random.default_rng(1)
    for p in np.column_stack([rng.uniform(0, 1e-3, 50), rng.uniform(0, 1e-3, 50), rng.uniform(-1.5e-3, 1e-3, 50)]):
        f = r.step(p)
        want = alg.force(p)
        n = np.linalg.norm(want)
        want = want * min(1.0, 5.0 / n) if n > 0 else want
        assert len(f) == 3
        np.testing.assert_allclose(f, want, rtol=1e-9, atol=1e-12)
    for bad in ([0.0, -1e-3], [np.nan, 0.0, -1e-3], [0.0, 2e3, -1e-3], "abc", [0.0, True, -1e-3], None):
        assert r.step(bad) == (0.0, 0.0, 0.0)
    assert r.faults == 6 and r.max_work >= 1


# -- the passivity controller ----------------------------------------------------------------
@pytest.mark.parametrize("letter, d", [("A", 2), ("G", 2), ("A", 3), ("G", 3)])
def test_the_passivity_controller_stops_a_texture_that_oscillates(letter, d):
    # Colgate & Schenkel (1997): a sampled virtual spring on a mass-damper is unstable above
    # about 2b/T (haptex.critical_stiffness: 10.0 kN/m for m = 0.1 kg, b = 0.5 N s/m,
    # T = 0.1 ms). Pushed by 1 N into the texture at 15 kN/m from a peak, A and G never come
    # to rest (a limit cycle, or bouncing off the surface). The passivity controller
    # (Hannaford & Ryu 2002; reference energy kappa_0 d^2 / 2) dissipates the energy the
    # zero-order hold generates: the motion dies out. Its added force is the damping it
    # reports, never more than max_damping |v|.
    assert hx.critical_stiffness(0.1, 0.5, 1e-4) == pytest.approx(10_000.8, rel=1e-5)
    tex = hx.Sinusoid(A, L) if d == 2 else hx.SumOfGratings.egg_crate(A, L)
    alg = hx.algorithm(letter, tex, 15_000.0)
    dev = hx.Device.point_mass(mass=0.1, damping=0.5, period=1e-4, dimension=d)
    push = ConstantForce([0.0, -1.0] if d == 2 else [0.0, 0.0, -1.0])
    start = [2.5e-4] * (d - 1) + [A if letter == "A" else 0.0]  # on the surface, at a peak
    free = hx.simulate(alg, dev, push, 1.0, initial_position=start)
    assert free.oscillating or free.oscillation.amplitude > 1e-4
    # the stored reference (the default "zero" lets the energy absorbed on entry run out first)
    pc = hx.PassivityController(max_damping=20.0, reference="stored")
    ctl = hx.simulate(alg, dev, push, 1.0, initial_position=start, passivity_controller=pc)
    assert not ctl.oscillating and not ctl.diverged and ctl.energy_balance_ok
    assert ctl.oscillation.amplitude < free.oscillation.amplitude / 10
    assert ctl.passivity_control_samples > 0
    # what it costs the texture: the controller's force is the command minus the field
    # (row k's force was computed from row k-1's position, its velocity estimate from rows k-2, k-1)
    extra = ctl.force[2:] - alg.force(ctl.position[1:-1])
    speed = np.linalg.norm(np.diff(ctl.position, axis=0), axis=1)[:-1] / dev.period
    assert np.all(np.linalg.norm(extra, axis=1) <= 20.0 * speed * (1 + 1e-9) + 1e-12)


def test_the_renderer_controller_keeps_the_observed_energy_at_its_reference():
    # a probe pushed into W along a straight line and pulled back: with the reference "zero"
    # the observer's energy never stays below 0 by more than the damper can dissipate in one
    # tick; without the controller the zero-order hold leaves it below 0 after the cycle
    alg = hx.algorithm("W", None, 20_000.0)
    T = 1e-3
    z = np.r_[np.linspace(1e-4, -2e-3, 40), np.linspace(-2e-3, 1e-4, 40)]
    plain = hx.Renderer(alg, energy_monitor=True)
    ctl = hx.Renderer(alg, passivity_controller=hx.PassivityController(1e3, reference="zero"), period=T)
    for zi in z:
        plain.step([0.0, zi])
        ctl.step([0.0, zi])
    assert plain.energy < -1e-4  # the ZOH of a stiff spring generated energy
    assert ctl.energy > plain.energy and ctl.controller_active > 0
    assert ctl.energy >= -1e-12
    with pytest.raises(hx.ParameterError, match="period = None is not allowed"):
        hx.Renderer(alg, passivity_controller=hx.PassivityController(1.0))
    with pytest.raises(hx.ParameterError, match="max_damping = -1 is not allowed"):
        hx.PassivityController(-1.0)


# -- presets -----------------------------------------------------------------------------------
def test_the_serial_arm_jacobian_is_the_derivative_of_its_kinematics():
    from haptex.devices import serial_arm_kinematics

    q = np.array([0.3, 0.2, 0.5])
    _, J = serial_arm_kinematics(0.14, 0.14, q)
    h = 1e-7
    fd = np.column_stack([(serial_arm_kinematics(0.14, 0.14, q + h * e)[0]
                           - serial_arm_kinematics(0.14, 0.14, q - h * e)[0]) / (2 * h) for e in np.eye(3)])
    np.testing.assert_allclose(J, fd, rtol=1e-7, atol=1e-10)
    # at home the axes decouple: M = diag(I_1 / l_1^2, I_3 / l_2^2, I_2 / l_1^2) + m_tip
    home = hx.Device.serial_arm()
    np.testing.assert_allclose(home.mass, np.diag([1e-3 / 0.14**2, 6.5e-4 / 0.14**2, 6.5e-4 / 0.14**2]) + 0.02 * np.eye(3),
                               rtol=1e-12)
    assert home.max_stiffness == 3500.0 and home.dimension == 3  # the published 3.5 N/mm
    bent = hx.Device.serial_arm(joint_angles=(0.3, 0.2, 0.5))
    assert abs(bent.mass[1, 2]) > 1e-3 * bent.mass[1, 1]  # configuration-dependent coupling
    with pytest.raises(hx.ParameterError, match="joint_angles = .* is not allowed"):
        hx.Device.serial_arm(joint_angles=(0.0, 0.0, math.pi / 2))


def test_the_delta_is_symmetric_at_its_centre_and_its_jacobian_is_the_constraints():
    from haptex.devices import delta_kinematics

    dev = hx.Device.delta()
    M = dev.mass
    # three-fold symmetry about z: M_xx = M_yy and no coupling
    assert M[0, 0] == pytest.approx(M[1, 1], rel=1e-12)
    assert np.abs(M - np.diag(np.diag(M))).max() < 1e-12 * M.max()
    # J against finite differences of the motor angles solved at displaced positions
    p = np.array([0.01, -0.005, -0.11])
    J, th = delta_kinematics(0.06, 0.02, 0.10, 0.13, p)
    h = 1e-7
    dth = np.column_stack([(delta_kinematics(0.06, 0.02, 0.10, 0.13, p + h * e)[1]
                            - delta_kinematics(0.06, 0.02, 0.10, 0.13, p - h * e)[1]) / (2 * h) for e in np.eye(3)])
    np.testing.assert_allclose(np.linalg.inv(J), dth, rtol=1e-6, atol=1e-6)
    with pytest.raises(hx.ParameterError, match="cannot reach"):
        hx.Device.delta(working_point=(0.0, 0.0, -0.5))
