//! What the instance check costs an entry point, side by side in one run: the export
//! layer's registry look-up (a hit in the instance's slot, the path of every call in a
//! master's loop; and a pointer that is not live, refused by its slot and the overflow
//! map's count without the lock while no instance waits there), beside whole
//! `Get*`/`Set*` calls of one value on the plant through both standards.
//!
//! `cargo bench -p inchworm-fmu-models --bench instance_check`

use std::hint::black_box;
use std::time::Instant;

use inchworm_fmi_export::api::Fmi2;
use inchworm_fmi_export::fmi3::api::Fmi3;
use inchworm_fmi_export::registry;
use inchworm_fmi_export::testing::{Harness, Master};
use inchworm_fmu_models::PlantFmu;

const CALLS: u32 = 2_000_000;
const ROUNDS: usize = 7;

/// Median over [`ROUNDS`] of the time per call of `f`, in ns.
fn per_call(mut f: impl FnMut()) -> f64 {
    let mut rounds: Vec<f64> = (0..ROUNDS)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..CALLS {
                f();
            }
            t.elapsed().as_secs_f64() * 1e9 / f64::from(CALLS)
        })
        .collect();
    rounds.sort_by(f64::total_cmp);
    rounds[ROUNDS / 2]
}

fn get_set<S: Master>() -> (f64, f64) {
    let h = Harness::<PlantFmu, S>::init("bench");
    let (position, dac) =
        (PlantFmu::RUNNER_POSITION.vr(), PlantFmu::var(inchworm_plant::Dac::EXTENSION).vr());
    let mut x = 0.0;
    let get = per_call(|| unsafe {
        black_box(S::get_reals::<PlantFmu>(h.c, &position, 1, &mut x));
    });
    let set = per_call(|| unsafe {
        black_box(S::set_reals::<PlantFmu>(h.c, &dac, 1, &5.0));
    });
    (get, set)
}

fn main() {
    let h = Harness::<PlantFmu, Fmi3>::init("probe");
    let inst = h.c as *const inchworm_fmi_export::instance::Instance<Fmi3, PlantFmu>;
    let hit = per_call(|| {
        black_box(registry::is_live(black_box(inst)));
    });
    // A pointer of the right address and the wrong type: its slot holds another, and
    // the overflow map is empty.
    let miss = per_call(|| {
        black_box(registry::is_live(black_box(inst as *const u8)));
    });
    // What a check costs that trusts the pointer and reads a tag through it (which a
    // junk or unmapped pointer turns into a crash): the floor the registry is held to.
    let tag = unsafe { *(h.c as *const u64) };
    let read = per_call(|| {
        black_box(unsafe { *(black_box(h.c) as *const u64) } == tag);
    });
    let (get2, set2) = get_set::<Fmi2>();
    let (get3, set3) = get_set::<Fmi3>();
    println!("instance check, a live instance: {hit:6.2} ns a call");
    println!("instance check, not live:        {miss:6.2} ns a call ({:.1}x the hit)", miss / hit);
    println!(
        "a tag read through the pointer:  {read:6.2} ns a call (the hit costs {:.2} ns more)",
        hit - read
    );
    for (what, t) in [
        ("fmi2GetReal", get2),
        ("fmi2SetReal", set2),
        ("fmi3GetFloat64", get3),
        ("fmi3SetFloat64", set3),
    ] {
        println!("{what:15} one value:     {t:6.2} ns a call, the check included");
    }
}
