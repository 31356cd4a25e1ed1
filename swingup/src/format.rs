//! Numbers as the reports print them, and as configuration files give them.

use serde::Deserialize as _;

/// A number with about four significant digits, `—` if not finite.
pub fn num(x: f64) -> String {
    if !x.is_finite() {
        return "—".into();
    }
    let a = x.abs();
    if a == 0.0 {
        "0".into()
    } else if (1e-3..1e5).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.3e}")
    }
}

/// A fixed-length array of a configuration file, refused unless it has
/// exactly `N` elements (`toml` would drop extra ones silently).
pub fn exact_array<'de, D: serde::Deserializer<'de>, const N: usize>(d: D) -> Result<[f64; N], D::Error> {
    let v = Vec::<f64>::deserialize(d)?;
    <[f64; N]>::try_from(v.as_slice())
        .map_err(|_| serde::de::Error::invalid_length(v.len(), &format!("an array of exactly {N} numbers").as_str()))
}
