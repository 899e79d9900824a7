//! The serialised form of the laws and their gains (`Law<N>`, `NnGains<N>`, `PdGains<N>`,
//! `CtcGains<N>`), for the planar `N = 3` and the spatial `N = 6`: the field names and the
//! `N`-dependent default and skip rules (`network`, `gravity_compensation`) are those of the
//! planar and spatial types they replaced, byte for byte (the expected texts were written by
//! those types).

use tandem::control::law::Law;
use tandem::control::law::adaptive::{NnGains, Smoothing};
use tandem::control::law::ctc::CtcGains;
use tandem::control::law::pd::PdGains;
use tandem::control::rbf::structured::NetworkStructure;

fn json<T: serde::Serialize>(v: &T) -> String {
    serde_json::to_string(v).unwrap()
}

#[test]
fn planar_laws_serialise_as_before() {
    // The paper's full grid is the default and is not written; any other network is.
    assert_eq!(
        json(&Law::Nn(NnGains::paper())),
        r#"{"kind":"nn","k1":[15.0,20.0,15.0],"k2":[11.0,15.0,10.0],"k_r":[0.01,0.01,0.01],"theta":[120.0,150.0,120.0],"sigma":[0.001,0.001,0.001],"varpi":0.05,"fu_safety":1.5,"width2":50.0,"levels":[-1.0,1.0],"d1":1.0,"d2":1.5,"omega":1.0}"#
    );
    let mut g = NnGains::tuned();
    g.network = NetworkStructure::per_axis();
    assert_eq!(
        json(&Law::Nn(g)),
        r#"{"kind":"nn","k1":[8.0,8.0,8.0],"k2":[233.0,700.0,50.0],"k_r":[0.001,0.001,0.001],"theta":[1.6,1.5,0.5],"sigma":[0.001,0.001,0.001],"varpi":0.05,"fu_safety":1.5,"width2":50.0,"levels":[-1.0,1.0],"d1":1.0,"d2":1.5,"omega":1.0,"network":{"kind":"per_axis","inputs":[]}}"#
    );
    // `gravity_compensation` is written only when on.
    assert_eq!(
        json(&Law::Pd(PdGains::<3>::paper())),
        r#"{"kind":"pd","k_p":[5000.0,5000.0,1000.0],"k_d":[450.0,450.0,350.0]}"#
    );
    let on = PdGains {
        gravity_compensation: true,
        ..PdGains::<3>::paper()
    };
    assert_eq!(
        json(&on),
        r#"{"k_p":[5000.0,5000.0,1000.0],"k_d":[450.0,450.0,350.0],"gravity_compensation":true}"#
    );
    assert_eq!(
        json(&Law::<3>::Ctc(CtcGains::default())),
        r#"{"kind":"ctc","k_p":[400.0,400.0,400.0],"k_d":[40.0,40.0,40.0],"model_error":0.0}"#
    );
}

#[test]
fn spatial_laws_serialise_as_before() {
    // The network is always written (per axis by default, the full grid too), and so is the
    // robust term's smoothing (`sampled` by default, with the radii d1 = 2, d2 = 3 of the
    // smooth design: docs/smooth-nn.md).
    assert_eq!(
        json(&Law::Nn(NnGains::dual_ur5())),
        r#"{"kind":"nn","k1":[8.0,8.0,8.0,8.0,8.0,8.0],"k2":[640.0,480.0,384.00000000000006,0.96,25.600000000000005,28.800000000000004],"k_r":[0.001,0.001,0.001,0.001,0.001,0.001],"theta":[586.7554354959052,440.0665766219289,352.0532612975431,0.8801331532438578,23.470217419836207,26.403994597315734],"sigma":[5.379405329437334e-6,5.379405329437334e-6,5.379405329437334e-6,5.379405329437334e-6,5.379405329437334e-6,5.379405329437334e-6],"varpi":0.05,"fu_safety":1.5,"width2":50.0,"levels":[-1.0,1.0],"d1":2.0,"d2":3.0,"omega":1.0,"network":{"kind":"per_axis","inputs":[]},"smoothing":"sampled"}"#
    );
    let mut full = NnGains::dual_ur5();
    full.network = NetworkStructure::FullGrid;
    assert_eq!(
        json(&Law::Nn(full)),
        r#"{"kind":"nn","k1":[8.0,8.0,8.0,8.0,8.0,8.0],"k2":[640.0,480.0,384.00000000000006,0.96,25.600000000000005,28.800000000000004],"k_r":[0.001,0.001,0.001,0.001,0.001,0.001],"theta":[586.7554354959052,440.0665766219289,352.0532612975431,0.8801331532438578,23.470217419836207,26.403994597315734],"sigma":[5.379405329437334e-6,5.379405329437334e-6,5.379405329437334e-6,5.379405329437334e-6,5.379405329437334e-6,5.379405329437334e-6],"varpi":0.05,"fu_safety":1.5,"width2":50.0,"levels":[-1.0,1.0],"d1":2.0,"d2":3.0,"omega":1.0,"network":{"kind":"full_grid"},"smoothing":"sampled"}"#
    );
    let paper = json(&Law::Nn(NnGains::dual_ur5().with_paper_switching()));
    assert!(
        paper.ends_with(r#""d1":1.0,"d2":1.5,"omega":1.0,"network":{"kind":"per_axis","inputs":[]},"smoothing":"paper"}"#),
        "{paper}"
    );
    // `gravity_compensation` is always written.
    assert_eq!(
        json(&Law::Pd(PdGains::<6>::paper())),
        r#"{"kind":"pd","k_p":[5000.0,5000.0,5000.0,200.0,200.0,200.0],"k_d":[450.0,450.0,450.0,18.0,18.0,18.0],"gravity_compensation":false}"#
    );
    assert_eq!(
        json(&Law::<6>::Ctc(CtcGains::default())),
        r#"{"kind":"ctc","k_p":[400.0,400.0,400.0,400.0,400.0,400.0],"k_d":[40.0,40.0,40.0,40.0,40.0,40.0],"model_error":0.0}"#
    );
}

/// The NN fields without `network`, on `n` outputs.
fn nn_without_network(n: usize) -> String {
    let a = format!("[{}]", vec!["1.0"; n].join(","));
    format!(
        r#"{{"kind":"nn","k1":{a},"k2":{a},"k_r":{a},"theta":{a},"sigma":{a},"varpi":1,"fu_safety":1,"width2":1,"levels":[1],"d1":1,"d2":2,"omega":1}}"#
    )
}

#[test]
fn defaults_and_refusals_are_as_before() {
    // `network` left out: the full grid when planar, per axis when spatial.
    let Law::Nn(g) = serde_json::from_str::<Law<3>>(&nn_without_network(3)).unwrap() else {
        panic!()
    };
    assert_eq!(g.network, NetworkStructure::FullGrid);
    let Law::Nn(g) = serde_json::from_str::<Law<6>>(&nn_without_network(6)).unwrap() else {
        panic!()
    };
    assert_eq!(g.network, NetworkStructure::per_axis());
    // `smoothing` left out: the paper's when planar, `sampled` when spatial; planar writes it
    // only when it is not the paper's.
    assert_eq!(g.smoothing, Smoothing::Sampled);
    let Law::Nn(g) = serde_json::from_str::<Law<3>>(&nn_without_network(3)).unwrap() else {
        panic!()
    };
    assert_eq!(g.smoothing, Smoothing::Paper);
    let sampled = NnGains {
        smoothing: Smoothing::Sampled,
        ..NnGains::tuned()
    };
    assert!(json(&sampled).ends_with(r#","smoothing":"sampled"}"#));
    assert!(!json(&NnGains::tuned()).contains("smoothing"));
    // `gravity_compensation` left out: off, for both.
    let pd3: Law<3> = serde_json::from_str(r#"{"kind":"pd","k_p":[1,2,3],"k_d":[4,5,6]}"#).unwrap();
    assert_eq!(
        pd3,
        Law::Pd(PdGains {
            k_p: [1.0, 2.0, 3.0],
            k_d: [4.0, 5.0, 6.0],
            gravity_compensation: false
        })
    );
    let pd6: Law<6> =
        serde_json::from_str(r#"{"kind":"pd","k_p":[1,2,3,1,1,1],"k_d":[4,5,6,1,1,1]}"#).unwrap();
    assert!(matches!(pd6, Law::Pd(g) if !g.gravity_compensation));
    // Round trips.
    for l in [
        Law::Nn(NnGains::tuned()),
        Law::Nn(sampled),
        Law::Pd(PdGains {
            gravity_compensation: true,
            ..PdGains::<3>::paper()
        }),
        Law::Pd(PdGains::<3>::paper()),
        Law::Ctc(CtcGains::default()),
    ] {
        assert_eq!(serde_json::from_str::<Law<3>>(&json(&l)).unwrap(), l);
    }
    for l in [
        Law::Nn(NnGains::dual_franka()),
        Law::Pd(PdGains::<6>::paper()),
        Law::Ctc(CtcGains::default()),
    ] {
        assert_eq!(serde_json::from_str::<Law<6>>(&json(&l)).unwrap(), l);
    }
    // Wrong lengths, missing and unknown fields: serde's messages.
    let e = serde_json::from_str::<Law<6>>(&nn_without_network(3)).unwrap_err();
    assert_eq!(
        e.to_string(),
        "invalid length 3, expected an array of length 6"
    );
    let e = serde_json::from_str::<Law<3>>(&nn_without_network(6)).unwrap_err();
    assert_eq!(
        e.to_string(),
        "invalid length 6, expected 3 elements in sequence"
    );
    let e = serde_json::from_str::<Law<3>>(r#"{"kind":"ctc","k_p":[1,2,3],"k_d":[4,5,6]}"#)
        .unwrap_err();
    assert_eq!(e.to_string(), "missing field `model_error`");
    let e = serde_json::from_str::<Law<3>>(r#"{"kind":"pd","k_p":[1,2,3],"k_d":[4,5,6],"x":1}"#)
        .unwrap_err();
    assert!(e.to_string().starts_with("unknown field `x`"), "{e}");
}
