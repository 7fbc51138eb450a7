//! `closed_loop::run_loop` and its step hook on the paper's arm: a hook's change of the
//! truth (a grasp) and of the controller's model act from the step they are made at.
//! Expected behaviour from the error dynamics of computed torque, `e'' + Kd e' + Kp e`
//! = the model's torque error through `M^-1`: zero with the true model (up to the friction
//! the controller and the simulator model differently), `M^-1 dtau` without the payload.

use ivdyn::closed_loop::{Controller, LoopController, StepHook, StepOutcome, run_loop};
use ivdyn::error::Result;
use ivdyn_core::control::{CoulombVelocity, Gains, Reference};
use ivdyn_core::sim::{SimConfig, Simulator};
use ivdyn_core::{Model, VecN};

/// A smooth reference: joint `i` swings `0.4 sin(2 pi 0.5 t + i)` about zero.
fn reference(k: usize) -> Reference<6> {
    let t = k as f64 * 1e-3;
    let w = std::f64::consts::TAU * 0.5;
    let ph = |i: usize| w * t + i as f64;
    Reference {
        q: VecN::<6>::from_fn(|i, _| 0.4 * ph(i).sin()),
        qd: VecN::<6>::from_fn(|i, _| 0.4 * w * ph(i).cos()),
        qdd: VecN::<6>::from_fn(|i, _| -0.4 * w * w * ph(i).sin()),
    }
}

/// At step `at`: the truth grasps a 0.25 kg point mass (the paper's payload) at the last link's origin; the
/// controller is told (its model becomes the loaded arm) when `tell`. Records the largest
/// tracking error from the grasp on, the calls, and every state.
struct Grasp {
    at: usize,
    tell: bool,
    loaded: Model<6>,
    max_err: f64,
    /// The largest tracking error before the grasp (the arm and the model agree there).
    max_err_before: f64,
    calls: (usize, usize),
    q: Vec<f64>,
}

impl StepHook<6> for Grasp {
    fn before(
        &mut self,
        k: usize,
        r: &Reference<6>,
        sim: &mut Simulator<6>,
        ctrl: &mut LoopController<6>,
    ) -> Result<()> {
        if k == self.at {
            sim.set_model(self.loaded.clone());
            if self.tell {
                ctrl.model = self.loaded.clone();
            }
        }
        let e = (r.q - sim.q).amax();
        if k >= self.at {
            self.max_err = self.max_err.max(e);
        } else {
            self.max_err_before = self.max_err_before.max(e);
        }
        self.q.extend_from_slice(sim.q.as_slice());
        self.calls.0 += 1;
        Ok(())
    }

    fn after(&mut self, _: usize, _: &StepOutcome<6>, _: &Simulator<6>, _: &mut LoopController<6>) -> Result<()> {
        self.calls.1 += 1;
        Ok(())
    }
}

fn run(at: usize, tell: bool, start_loaded: bool) -> Grasp {
    let nominal = ivdyn_core::paper::robot();
    let mut loaded = nominal.clone();
    loaded.inertia[5].0[0] += 0.25;
    let r0 = reference(0);
    let mut sim = Simulator::new(nominal.clone(), SimConfig::ideal(), &r0.q, &r0.qd).unwrap();
    let start = if start_loaded { loaded.clone() } else { nominal.clone() };
    let gains = Gains::<6>::critically_damped(20.0);
    let mut ctrl = LoopController::new(Controller::ComputedTorque, start, gains, CoulombVelocity::Reference, &r0.q);
    let mut g = Grasp { at, tell, loaded, max_err: 0.0, max_err_before: 0.0, calls: (0, 0), q: vec![] };
    run_loop(&mut sim, &mut ctrl, 3000, reference, &mut g).unwrap();
    g
}

#[test]
fn the_hook_is_called_around_every_step() {
    let g = run(1000, true, false);
    assert_eq!(g.calls, (3000, 3000));
}

/// Told of the grasp, computed torque tracks as well as before it: with the true model the
/// error comes from Coulomb friction at velocity reversals (the simulator smooths it over
/// 0.05 rad/s, the controller takes `sign(qd_d)`), which the payload does not change. Not
/// told, the payload's weight through the light wrist's `M^-1` over `Kp = 400 /s^2` leaves
/// an error of a different order.
#[test]
fn a_model_written_by_the_hook_is_the_one_the_controller_uses() {
    let told = run(1000, true, false);
    let untold = run(1000, false, false);
    let before = told.max_err_before;
    assert!(before > 0.0 && untold.max_err_before == before, "{before} vs {}", untold.max_err_before);
    assert!(told.max_err < 1.5 * before, "told: {} after the grasp, {before} before", told.max_err);
    assert!(untold.max_err > 10.0 * before, "not told: {} after the grasp, {before} before", untold.max_err);
}

/// A model written before the first command is bit for bit a controller that started
/// with it: the `before` hook acts at its own step.
#[test]
fn a_change_in_before_acts_at_the_same_step() {
    let written = run(0, true, false);
    let started = run(0, false, true);
    assert_eq!(written.q, started.q);
}
