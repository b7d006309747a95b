//! The time loop allocates nothing: a run of 1000 steps makes exactly as many heap allocations
//! as a run of 10 steps (all of them before the loop), with outputs at every step and an
//! external force. Counted per thread by a wrapping global allocator.

use linpd_dynamics::{Chain, DtLimit, State, Verlet, VerletParams};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::ops::ControlFlow;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations_of_a_run(steps: usize) -> usize {
    let ring = Chain::springs(1.0, 5, 0.5).unwrap().ring(64).unwrap();
    let verlet = Verlet::new(&ring, ring.mass(1.0).unwrap()).with_fixed(&[(0, 0.0)]).unwrap();
    let params = VerletParams {
        output_every: 1,
        limit: DtLimit::Given(ring.dt_limit(1.0)),
        ..VerletParams::new(0.5 * ring.dt_limit(1.0), steps)
    };
    let mut state = State::at_rest((0..64).map(|i| (i as f64 * 0.3).sin()).collect());
    let mut force = |t: f64, f: &mut [f64]| f[10] = t.cos();
    let mut energy = 0.0;
    let before = ALLOCATIONS.with(|c| c.get());
    verlet
        .run(&mut state, &params, Some(&mut force), |s| {
            energy += s.energy.total();
            ControlFlow::Continue(())
        })
        .unwrap();
    let after = ALLOCATIONS.with(|c| c.get());
    assert!(energy.is_finite());
    after - before
}

#[test]
fn time_loop_does_not_allocate() {
    let short = allocations_of_a_run(10);
    let long = allocations_of_a_run(1000);
    assert!(short > 0, "the counter works (buffers are allocated before the loop)");
    assert_eq!(short, long, "allocations grew with the number of steps");
}
