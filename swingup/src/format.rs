//! Numbers as the reports print them, and as configuration files give them.

use serde::Deserialize as _;

/// The largest value of any scalar weight, scale, bound or physical
/// setting, lambda included (`config::limits`): a weight $10^{15}$ times
/// another's leaves the smaller term below f64's 16 digits (the criterion
/// is the large term alone), and weights of $10^{308}$ overflow it to
/// infinity.
pub const MAX_MAGNITUDE: f64 = 1e15;

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

/// An `f64` that JSON holds as `null` when it was not finite (serde_json
/// writes NaN and infinities as `null`): read back as NaN, so that a
/// record with a NaN field (the random trial's replan times) reads back.
pub fn null_as_nan<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// [`null_as_nan`] for each number of a list.
pub fn nulls_as_nan<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    Ok(Vec::<Option<f64>>::deserialize(d)?
        .into_iter()
        .map(|x| x.unwrap_or(f64::NAN))
        .collect())
}

/// [`null_as_nan`] for each number of a list of 4-vectors (states).
pub fn state_nulls_as_nan<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<[f64; 4]>, D::Error> {
    Ok(Vec::<[Option<f64>; 4]>::deserialize(d)?
        .into_iter()
        .map(|s| s.map(|x| x.unwrap_or(f64::NAN)))
        .collect())
}
