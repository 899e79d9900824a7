//! The actuator stage (issue 24, `control/actuator.rs`) over random torque sequences: the
//! applied torque never exceeds the effort limit, never changes faster than `r h` per tick, stays
//! finite whatever the command (NaN, ±∞, 1e308), with the filter on or off and from a cold or a
//! known start; the per-joint counts agree with the tick counts; and a tick allocates nothing
//! (the counting allocator of `support/counting.rs`).

use proptest::prelude::*;
use tandem::control::actuator::{Actuator, ActuatorParams};

#[path = "support/counting.rs"]
mod counting;

#[global_allocator]
static A: counting::Counting = counting::Counting;

/// One commanded torque: ordinary values, huge ones, and the non-finite ones.
fn torque() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => -200.0..200.0f64,
        1 => -1e6..1e6f64,
        1 => prop_oneof![Just(1e308), Just(-1e308), Just(1e300), Just(-f64::MAX)],
        1 => prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)],
        1 => Just(0.0),
    ]
}

/// Limits for `n` joints at period `h`: each limit on or off; an effort limit may be `+∞` on a
/// joint (a URDF joint without one); the filter's time constant from `h` to 50 `h`.
fn params(n: usize, h: f64) -> impl Strategy<Value = ActuatorParams> {
    (
        proptest::option::of(proptest::collection::vec(
            prop_oneof![4 => 0.1..300.0f64, 1 => Just(f64::INFINITY)],
            n,
        )),
        proptest::option::of(1.0..1e5f64),
        proptest::option::of(1.0..50.0f64),
    )
        .prop_map(move |(effort, rate_limit, tf)| ActuatorParams {
            effort,
            rate_limit,
            filter_time_constant: tf.map(|k| k * h),
            anti_windup: None,
        })
}

/// A case: period, limits, an optional known start torque, and the command sequence.
type Case = (f64, ActuatorParams, Option<Vec<f64>>, Vec<Vec<f64>>);

fn case() -> impl Strategy<Value = Case> {
    (
        1usize..8,
        prop_oneof![Just(1e-3), Just(2.5e-4), 1e-4..1e-2f64],
    )
        .prop_flat_map(|(n, h)| {
            (
                Just(h),
                params(n, h),
                proptest::option::of(proptest::collection::vec(torque(), n)),
                proptest::collection::vec(proptest::collection::vec(torque(), n), 1..60),
            )
        })
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 512,
        rng_seed: proptest::test_runner::RngSeed::Fixed(24),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// `|τ_k,j| ≤ E_j`, `|τ_k,j − τ_{k−1},j| ≤ r h` (from the first tick after a start, from the
    /// second without one), `τ` finite; the counts are consistent; no tick allocates.
    #[test]
    fn the_limits_hold_on_every_tick_and_a_tick_allocates_nothing(
        (h, p, start, seq) in case()
    ) {
        let n = seq[0].len();
        let mut act = Actuator::new(&p, n, h).unwrap();
        let effort = p.effort.clone().unwrap_or_else(|| vec![f64::INFINITY; n]);
        let step = p.rate_limit.map_or(f64::INFINITY, |r| r * h);
        let mut prev = vec![0.0; n];
        let mut have_prev = false;
        if let Some(t0) = &start {
            act.start(t0);
            prev.copy_from_slice(act.last());
            have_prev = true;
            // A start torque is clamped to the effort limit and made finite.
            for (j, v) in prev.iter().enumerate() {
                prop_assert!(v.is_finite() && v.abs() <= effort[j], "start {j}: {v}");
            }
        }
        let mut out = vec![0.0; n];
        for u in &seq {
            let allocs = counting::count(|| act.apply(u, &mut out));
            prop_assert_eq!(allocs, 0);
            for j in 0..n {
                let t = out[j];
                prop_assert!(t.is_finite(), "joint {j}: {t} from {}", u[j]);
                prop_assert!(t.abs() <= effort[j], "joint {j}: |{t}| > {}", effort[j]);
                if have_prev {
                    let d = (t - prev[j]).abs();
                    let tol = 1e-12 * step + 4.0 * f64::EPSILON * t.abs().max(prev[j].abs());
                    prop_assert!(d <= step + tol, "joint {j}: step {d} > r h = {step}");
                }
                // Without any limit or filter, a finite command within the range passes as is.
                if p == ActuatorParams::default() && u[j].is_finite() && u[j].abs() <= 1e300 {
                    prop_assert_eq!(t, u[j]);
                }
            }
            prev.copy_from_slice(&out);
            have_prev = true;
        }
        let c = act.counts();
        prop_assert_eq!(c.ticks, seq.len() as u64);
        prop_assert_eq!(c.rate_per_joint.len(), n);
        prop_assert_eq!(c.effort_per_joint.len(), n);
        for (per, total) in [(&c.rate_per_joint, c.rate), (&c.effort_per_joint, c.effort)] {
            prop_assert!(per.iter().all(|k| *k <= total));
            prop_assert!(per.iter().sum::<u64>() >= total);
            prop_assert!(total <= c.ticks);
        }
        if p.rate_limit.is_none() {
            prop_assert_eq!(c.rate, 0);
        }
        if p.effort.is_none() {
            prop_assert_eq!(c.effort, 0);
        }
    }
}

/// The failure the property found: an infinite command left the filter state infinite, the next
/// finite command made it NaN, and from then on the stage passed NaN through its limits (a NaN
/// compares false with both ends of the window). Now the stage takes it as `±1e300` and stays
/// finite and rate-limited.
#[test]
fn an_infinite_command_does_not_poison_the_filter() {
    let p = ActuatorParams {
        effort: Some(vec![10.0]),
        rate_limit: Some(1000.0),
        filter_time_constant: Some(0.01),
        anti_windup: None,
    };
    let mut a = Actuator::new(&p, 1, 1e-3).unwrap();
    let mut out = [0.0];
    let mut last = 0.0;
    for (k, u) in [0.0, f64::INFINITY, 1.0, f64::NAN, -5.0, 2.0]
        .into_iter()
        .enumerate()
    {
        a.apply(&[u], &mut out);
        assert!(out[0].is_finite(), "tick {k}: {}", out[0]);
        if k > 0 {
            assert!((out[0] - last).abs() <= 1.0 + 1e-12, "tick {k}");
        }
        last = out[0];
    }
}
