//! Golden vectors of docs/detectors.md, test-stimuli §3 (GOLD-1, n = 32, all defaults; CizFai19 with W_I = 0.6).
//! Values from the independent f64 prototype described there, printed to 7 significant digits: an f64 port
//! must match to ~1e−6 relative, spike counts exactly.

use loomlab_detector::Detector;
use loomlab_detector::baselines::{Cizek2019, Cizek2019Config, Fu2020, Fu2020Config, Keil2004, Keil2004Config};

use crate::stimuli::gold1;
use crate::{aux, outputs, run};

/// Per frame: Adv z_on (= z_off), Adv z, Ciz ẑ, Ciz z, Fu spikes on, Fu spikes off, Fu z.
#[rustfmt::skip]
const GOLD: [(f64, f64, f64, f64, f64, f64, f64); 16] = [
    (0.0,          0.0,          0.0,          0.0,          0.0, 0.0, 0.0),
    (9.765625e-04, 1.453400e-06, 9.765625e-04, 9.765625e-04, 0.0, 0.0, 0.0),
    (3.770690e-03, 1.160644e-05, 3.906250e-03, 3.906250e-03, 1.0, 1.0, 2.750000e-01),
    (0.0,          5.803221e-06, 2.343750e-03, 2.343750e-03, 0.0, 0.0, 2.062500e-01),
    (4.496859e-03, 1.750934e-05, 4.882812e-03, 4.882812e-03, 2.0, 2.0, 1.204688e+00),
    (5.929004e-03, 3.226021e-05, 7.275391e-03, 7.275391e-03, 2.0, 2.0, 1.953516e+00),
    (6.495430e-03, 4.372084e-05, 8.984375e-03, 8.984375e-03, 2.0, 2.0, 2.515137e+00),
    (8.882896e-03, 7.019624e-05, 1.191406e-02, 1.191406e-02, 2.0, 2.0, 2.936353e+00),
    (1.194484e-02, 1.183826e-04, 1.713867e-02, 1.713867e-02, 2.0, 2.0, 3.252264e+00),
    (2.016838e-02, 2.827413e-04, 2.866211e-02, 2.866211e-02, 2.0, 2.0, 3.489198e+00),
    (2.609705e-02, 5.079957e-04, 4.204102e-02, 4.204102e-02, 2.0, 2.0, 3.666899e+00),
    (4.016863e-02, 1.100926e-03, 6.296387e-02, 6.296387e-02, 1.0, 1.0, 3.025174e+00),
    (4.978288e-02, 1.839413e-03, 8.864746e-02, 8.864746e-02, 1.0, 1.0, 2.543881e+00),
    (1.936170e-02, 1.126506e-03, 7.082520e-02, 7.082520e-02, 1.0, 1.0, 2.182910e+00),
    (1.236138e-03, 5.652532e-04, 2.424316e-02, 0.0,          0.0, 0.0, 1.637183e+00),
    (0.0,          2.826266e-04, 2.490234e-03, 0.0,          0.0, 0.0, 1.227887e+00),
];

/// Relative agreement at the 7-significant-digit precision of the table.
fn assert_close(what: &str, t: usize, got: f64, want: f64) {
    let ok = if want == 0.0 {
        got.abs() <= 1e-15
    } else {
        ((got - want) / want).abs() <= 1e-6
    };
    assert!(ok, "{what} at t = {t}: got {got:.9e}, want {want:.6e}");
}

#[test]
fn golden_keil2004() {
    let s = run(&mut Keil2004::new(Keil2004Config::default()).unwrap(), &gold1());
    let (z, on, off) = (outputs(&s), aux(&s, "z_on"), aux(&s, "z_off"));
    for (t, g) in GOLD.iter().enumerate() {
        assert_close("keil2004 z_on", t, on[t], g.0);
        assert_close("keil2004 z_off", t, off[t], g.0);
        assert_close("keil2004 z", t, z[t], g.1);
    }
}

#[test]
fn golden_cizek2019() {
    let s = run(&mut Cizek2019::new(Cizek2019Config::default()).unwrap(), &gold1());
    let (z, z_hat) = (outputs(&s), aux(&s, "z_hat"));
    for (t, g) in GOLD.iter().enumerate() {
        assert_close("cizek2019 z_hat", t, z_hat[t], g.2);
        assert_close("cizek2019 z", t, z[t], g.3);
    }
}

#[test]
fn golden_fu2020() {
    let s = run(&mut Fu2020::new(Fu2020Config::default()).unwrap(), &gold1());
    let (z, on, off) = (outputs(&s), aux(&s, "z_on"), aux(&s, "z_off"));
    for (t, g) in GOLD.iter().enumerate() {
        assert_eq!((on[t], off[t]), (g.4, g.5), "fu2020 spikes at t = {t}");
        assert_close("fu2020 z", t, z[t], g.6);
    }
}

/// The golden numbers are reproduced after a reset too (state fully cleared).
#[test]
fn golden_survives_reset_and_reuse() {
    let frames = gold1();
    let mut m = Fu2020::new(Fu2020Config::default()).unwrap();
    let a = outputs(&run(&mut m, &frames));
    m.step(&frames[3]).unwrap();
    let b = outputs(&run(&mut m, &frames));
    assert_eq!(a, b);
    assert_eq!(m.id(), "fu2020");
}
