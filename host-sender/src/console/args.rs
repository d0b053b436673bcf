//! The numbers of the console's API, read and validated as the CLI's arguments are: a value of
//! the wrong type, not finite, not whole where a count is meant or outside its range is refused
//! with its name and the range, never rounded, clamped or ignored (`{"from_line":1e20}` is an
//! error, not a start from line 4294967295).

use serde_json::Value;

/// `key` as a finite number; `None` when absent or `null`.
pub(crate) fn num(v: &Value, key: &str) -> Result<Option<f64>, String> {
    match v.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(Value::Number(n)) => match n.as_f64() {
            Some(x) if x.is_finite() => Ok(Some(x)),
            _ => Err(format!("{key}: {n} is not a usable number")),
        },
        Some(other) => Err(format!("{key}: a number, not {other}")),
    }
}

/// `key` as a finite number within `lo..=hi` (`what` names its unit in the message).
pub(crate) fn num_in(
    v: &Value,
    key: &str,
    lo: f64,
    hi: f64,
    unit: &str,
) -> Result<Option<f64>, String> {
    match num(v, key)? {
        Some(x) if !(lo..=hi).contains(&x) => {
            Err(format!("{key} {x}{unit}: give {lo}{unit} to {hi}{unit}"))
        }
        x => Ok(x),
    }
}

/// `key` as a whole number within `lo..=hi`.
pub(crate) fn whole_in(v: &Value, key: &str, lo: u64, hi: u64) -> Result<Option<u64>, String> {
    match num(v, key)? {
        None => Ok(None),
        Some(x) if x.fract() != 0.0 || x < lo as f64 || x > hi as f64 => {
            Err(format!("{key} {x}: give a whole number from {lo} to {hi}"))
        }
        Some(x) => Ok(Some(x as u64)),
    }
}

/// An override percentage, whole, within the board's range for it (`gantry override`: feed
/// 10-200, rapid 1-100, spindle 10-200).
pub(crate) fn percent(v: &Value, key: &str, lo: u16, hi: u16) -> Result<Option<u16>, String> {
    match num(v, key)? {
        None => Ok(None),
        Some(p) if p.fract() == 0.0 && (f64::from(lo)..=f64::from(hi)).contains(&p) => {
            Ok(Some(p as u16))
        }
        Some(p) => Err(format!(
            "{key} override {p} %: give a whole number from {lo} to {hi}"
        )),
    }
}

/// `key` as a string; `None` when absent.
pub(crate) fn text<'a>(v: &'a Value, key: &str) -> Result<Option<&'a str>, String> {
    match v.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(Value::String(s)) => Ok(Some(s)),
        Some(other) => Err(format!("{key}: a string, not {other}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_line_number_must_be_whole_and_in_range() {
        let v = json!({"from_line": 1e20, "a": 12, "b": 2.5, "c": "7", "d": -1});
        assert!(whole_in(&v, "from_line", 1, 1000).is_err());
        assert_eq!(whole_in(&v, "a", 1, 1000), Ok(Some(12)));
        assert!(whole_in(&v, "b", 1, 1000).is_err());
        assert!(whole_in(&v, "c", 1, 1000).is_err());
        assert!(whole_in(&v, "d", 1, 1000).is_err());
        assert_eq!(whole_in(&v, "none", 1, 1000), Ok(None));
    }

    #[test]
    fn overrides_take_the_boards_ranges() {
        let v = json!({"feed": 5, "rapid": 100, "spindle": 150.5, "x": true});
        assert!(percent(&v, "feed", 10, 200).is_err());
        assert_eq!(percent(&v, "rapid", 1, 100), Ok(Some(100)));
        assert!(percent(&v, "spindle", 10, 200).is_err());
        assert!(percent(&v, "x", 10, 200).is_err());
        assert_eq!(num_in(&v, "rapid", 0.0, 1000.0, " mm"), Ok(Some(100.0)));
        assert!(num_in(&v, "rapid", 0.0, 10.0, " mm").is_err());
    }
}
