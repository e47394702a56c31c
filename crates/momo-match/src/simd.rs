//! Run-time dispatch of the front end's hot kernels to AVX2.
//!
//! The workspace compiles for the x86-64 baseline (SSE2). The kernels below (the filter rows,
//! the two passes of the non-maximum suppression per row of blocks, the descriptor search per
//! candidate, the KLT refinement per match) are compiled twice: once for the baseline and once
//! with `#[target_feature(enable = "avx2")]`, where the compiler's vectorised loops take 32
//! bytes at a time. Which one runs is decided per call from
//! [`is_x86_feature_detected!`](std::arch::is_x86_feature_detected) (cached by `std`). Both
//! compile the same source, which is integer arithmetic or `f32`/`f64` arithmetic without
//! fused multiply-adds (Rust does not contract `a * b + c`, and FMA is not enabled), so both
//! give the same bits: the features and matches are identical (tests compare them).
//!
//! [`set_isa`] forces the baseline (tests, measurements); the environment variable
//! `MOMO_ISA=baseline` does the same for a whole process.
//!
//! This is the crate's only `unsafe` code: calling a `#[target_feature]` function from code
//! compiled without the feature is `unsafe`, and sound only after the CPU was checked.

#![allow(unsafe_code)]

use std::sync::atomic::{AtomicU8, Ordering};

/// The instruction set of the front end's hot kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// The x86-64 baseline (SSE2), or whatever the build targets elsewhere.
    Baseline,
    /// AVX2 (x86-64 only, where the CPU has it).
    Avx2,
}

/// 0: not decided yet; 1: baseline; 2: AVX2.
static CHOICE: AtomicU8 = AtomicU8::new(0);

/// The best instruction set this CPU offers.
fn available() -> Isa {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            return Isa::Avx2;
        }
    }
    Isa::Baseline
}

/// Forces the kernels onto `isa` (`None`: the best available, unless `MOMO_ISA=baseline`).
/// Returns the instruction set now in use: AVX2 is not used where the CPU lacks it. Process
/// wide; the features and matches do not depend on it (only the speed).
pub fn set_isa(isa: Option<Isa>) -> Isa {
    let chosen = match isa {
        Some(Isa::Baseline) => Isa::Baseline,
        Some(Isa::Avx2) => available(),
        None => {
            let forced =
                std::env::var("MOMO_ISA").is_ok_and(|v| v.eq_ignore_ascii_case("baseline"));
            if forced { Isa::Baseline } else { available() }
        }
    };
    CHOICE.store(
        match chosen {
            Isa::Baseline => 1,
            Isa::Avx2 => 2,
        },
        Ordering::Relaxed,
    );
    chosen
}

/// The instruction set the kernels use (decided on first use, see [`set_isa`]).
pub fn isa() -> Isa {
    match CHOICE.load(Ordering::Relaxed) {
        1 => Isa::Baseline,
        2 => Isa::Avx2,
        _ => set_isa(None),
    }
}

/// Defines `pub(crate) fn NAME(args) -> R` that runs `BODY(args)` (an `#[inline(always)]`
/// function) compiled for AVX2 where [`isa`] says so, else compiled for the baseline. Each
/// variant is a function of its own (not inlined into the caller).
macro_rules! kernels {
    ($(
        $(#[$doc:meta])*
        fn $name:ident $(<$($lt:lifetime),+>)? ($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? = $body:path;
    )*) => {$(
        $(#[$doc])*
        #[inline]
        pub(crate) fn $name $(<$($lt),+>)? ($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2")]
                #[inline(never)]
                fn avx2 $(<$($lt),+>)? ($($arg: $ty),*) $(-> $ret)? {
                    $body($($arg),*)
                }
                if isa() == Isa::Avx2 {
                    // SAFETY: `isa()` is `Avx2` only where `is_x86_feature_detected!("avx2")`
                    // held, so the CPU executes the AVX2 instructions of `avx2`.
                    return unsafe { avx2($($arg),*) };
                }
            }
            #[inline(never)]
            fn baseline $(<$($lt),+>)? ($($arg: $ty),*) $(-> $ret)? {
                $body($($arg),*)
            }
            baseline($($arg),*)
        }
    )*};
}

use crate::features::{
    self, CLASSES, Extremum, Feature, FrameFeatures, LaneOffsets, SlidingScratch,
};
use crate::matcher::{self, FlowPrior, Match, MatchOptions};
use crate::refine::{self, KltOptions, Plane};

kernels! {
    /// [`features::filter_row`], dispatched.
    fn filter_row(
        rows: [&[u8]; 5],
        rb: &mut [i16],
        rc: &mut [i16],
        scratch: [&mut [i16]; 3],
        sobel: [&mut [i16]; 2],
        rs: &mut [u16],
    ) = features::filter_row;

    /// [`features::pass_one_row`], dispatched.
    fn pass_one_row(
        blob: &[i16],
        corner: &[i16],
        w: usize,
        h: usize,
        v0: usize,
        n: usize,
        tau: i16,
        cols: &mut [Vec<i16>; CLASSES],
        scratch: &mut [SlidingScratch; CLASSES],
    ) -> Vec<Extremum> = features::pass_one_row;

    /// [`features::pass_two_row`], dispatched.
    fn pass_two_row(
        row: &[Extremum],
        blob: &[i16],
        corner: &[i16],
        sobel: &[u16],
        w: usize,
        h: usize,
        n: usize,
        lanes: &LaneOffsets,
    ) -> [Vec<Feature>; CLASSES] = features::pass_two_row;

    /// [`matcher::match_candidate`], dispatched.
    fn match_candidate(
        prev: &FrameFeatures,
        cur: &FrameFeatures,
        options: &MatchOptions,
        prior: Option<&FlowPrior>,
        class: usize,
        i: usize,
        ru: i32,
        rv: i32,
    ) -> Option<Match> = matcher::match_candidate;

    /// [`refine::align`], dispatched.
    fn align(
        from: Plane<'_>,
        to: Plane<'_>,
        u: usize,
        v: usize,
        d0: [f64; 2],
        options: &KltOptions,
    ) -> Option<[f64; 2]> = refine::align_body;
}
