//! Calls every core algorithm so that the linker sees them all.
#![no_std]
#![no_main]

use core::panic::PanicInfo;
use ivdyn_core::estim::terminal::{Method, TerminalLink, TerminalSpec};
use ivdyn_core::estim::{Riv, RivInfo, Rls};
use ivdyn_core::nalgebra::{Const, SVector};
use ivdyn_core::{paper, Data, VecN};

#[panic_handler]
fn panic(_info: &PanicInfo) -> ! {
    loop {}
}

#[unsafe(no_mangle)]
pub extern "C" fn _start() -> ! {
    let model = paper::robot();
    let mut data = Data::<6>::new();
    let q = VecN::<6>::from_element(0.1);
    let qd = VecN::<6>::from_element(0.2);
    let qdd = VecN::<6>::from_element(0.3);
    let tau = *ivdyn_core::rnea(&model, &mut data, &q, &qd, &qdd);
    let y = ivdyn_core::regressor(&model, &mut data, &q, &qd, &qdd).clone();
    let _ = ivdyn_core::gravity_regressor(&model, &mut data, &q);
    let _ = ivdyn_core::mass_matrix(&model, &mut data, &q);
    let _ = ivdyn_core::forward_dynamics(&model, &mut data, &q, &qd, &tau);
    let _ = ivdyn_core::energy::kinetic_energy(&model, &mut data, &q, &qd);
    let _ = core::hint::black_box(y.get(0, 0));
    // the terminal-link update (reduced rows, sparse IV rows) and its full reference
    let cols = SVector::<usize, 18>::from([1, 4, 5, 7, 8, 9, 10, 11, 13, 14, 15, 16, 17, 19, 20, 21, 22, 23]);
    let iv = Method::Iv(Riv::new(SVector::<f64, 18>::zeros(), 1e4));
    let mut tl = TerminalLink::<6, Const<18>>::new(model.clone(), TerminalSpec::PAPER, cols, [1.0; 6], iv);
    let _ = tl.update(&q, &qd, &qdd, &tau, &qdd);
    let _ = tl.update_full(&q, &qd, &qdd, &tau, &qdd);
    // the information form, in f32 (a small controller's build)
    let info = Method::IvInfo(RivInfo::new(SVector::<f32, 18>::zeros(), 1e4));
    let mut tli = TerminalLink::<6, Const<18>, f32>::new(model.clone(), TerminalSpec::PAPER, cols, [1.0; 6], info);
    let v = VecN::<6>::from_element(0.2).map(|x| x as f32);
    let _ = tli.update(&v, &v, &v, &v, &v);
    let _ = core::hint::black_box(tli.theta()[0]);
    let ls = Method::Ls(Rls::new(SVector::<f32, 18>::zeros(), 1e4));
    let mut tl32 = TerminalLink::<6, Const<18>, f32>::new(model, TerminalSpec::PAPER, cols, [1.0; 6], ls);
    let _ = tl32.update(&v, &v, &v, &v, &v);
    let _ = core::hint::black_box((tl.theta()[0], tl32.theta()[0]));
    loop {}
}
