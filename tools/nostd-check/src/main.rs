//! Calls every core algorithm so that the linker sees them all.
#![no_std]
#![no_main]

use core::panic::PanicInfo;
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
    loop {}
}
