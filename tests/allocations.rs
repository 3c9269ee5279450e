//! A step of a small scene allocates nothing once the stepper's buffers have grown: the impact
//! stepper keeps its problems, solutions, poses, material points and contact points from step
//! to step (see `native::stepper`'s `Workspace`). Counted by a global allocator that counts the
//! allocations of the thread that asks (tests run on threads of their own).

use rockbench::native::stepper_for;
use rockbench::scene::{Scene, parse_scene_str};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: every call is forwarded to the system allocator unchanged; the count is a
// thread-local `Cell` with a const initialiser, which does not allocate.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|n| n.set(n.get() + 1));
        // SAFETY: the caller's contract is the system allocator's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|n| n.set(n.get() + 1));
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|n| n.set(n.get() + 1));
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static COUNTING: Counting = Counting;

fn allocations() -> u64 {
    ALLOCATIONS.with(Cell::get)
}

/// A rocking block (1.0 x 2.5 m, tilted 0.15 rad) or the two-block case's stack (the scenes of
/// the per-step cost benchmark, `benches/step_cost.rs`).
fn rocking(blocks: usize, stepper: &str) -> Scene {
    let body = match blocks {
        1 => "[[blocks]]\nname = \"b0\"\nwidth = 1.0\nheight = 2.5\n",
        _ => {
            "[[blocks]]\nname = \"b0\"\nwidth = 1.25\nheight = 1.25\n\
             [[blocks]]\nname = \"b1\"\nwidth = 1.0\nheight = 2.5\n"
        }
    };
    let text = format!("name = \"rocking\"\nduration = 1.0\n{body}[initial]\ntilt = 0.15\n");
    let mut scene = parse_scene_str(&text, false, "rocking", &[]).unwrap();
    scene.set_setting("native", "stepper", stepper);
    scene
}

/// Allocations of steps 101-200 (no impact within them: the blocks are still falling onto
/// their corners).
fn allocations_of_rocking_steps(blocks: usize, stepper: &str) -> u64 {
    let (mut st, mut state) = stepper_for(&rocking(blocks, stepper)).unwrap();
    for _ in 0..100 {
        st.step(&mut state).unwrap();
    }
    let splits = st.split_steps;
    let before = allocations();
    for _ in 0..100 {
        st.step(&mut state).unwrap();
    }
    let counted = allocations() - before;
    assert_eq!(
        st.split_steps, splits,
        "a located impact within the counted steps"
    );
    counted
}

#[test]
fn a_step_of_a_rocking_block_allocates_nothing() {
    for stepper in ["impact", "paper"] {
        let n = allocations_of_rocking_steps(1, stepper);
        assert_eq!(n, 0, "{stepper}: {n} allocations in 100 steps");
    }
}

#[test]
fn a_step_of_the_two_block_case_allocates_nothing() {
    for stepper in ["impact", "paper"] {
        let n = allocations_of_rocking_steps(2, stepper);
        assert_eq!(n, 0, "{stepper}: {n} allocations in 100 steps");
    }
}

/// The counter counts: a step from a fresh stepper grows its buffers.
#[test]
fn the_first_step_allocates() {
    let (mut st, mut state) = stepper_for(&rocking(1, "impact")).unwrap();
    let before = allocations();
    st.step(&mut state).unwrap();
    assert!(allocations() > before);
}
