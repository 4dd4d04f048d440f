//! Mission times and durations: one grammar for scenario files and task networks.
//!
//! **Times** are mission times, relative to the epoch (mission time 0, the task network's
//! `[network] epoch`, by default `2028-040T00:00`):
//! - `"10:30"`, `"10:30:15"`, `"10:30:15.250"`: that time on the epoch day;
//! - `"1T10:30"`: that time 1 day after the epoch day;
//! - `"2028-041T10:30"`: year and day of year (on or after the epoch);
//! - an integer: seconds since the epoch.
//!
//! **Durations**: `"15min"` (or `"15m"`), `"90s"`, `"1h30min"`, `"250ms"`, `"20us"`, `"2d"`,
//! with spaces allowed (`"15 min"`), or an integer number of seconds. Offsets (task-network
//! constraint and impact offsets, temporal bounds) may start with `-`.
use fsw_bridge::MissionTimeUs;
use serde::Deserialize;

const SEC: u64 = 1_000_000;
const DAY_US: i64 = 86_400 * 1_000_000;

/// A time or duration as a TOML file writes it: a string in the grammar above, or an integer
/// number of seconds.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(untagged)]
pub enum TimeText {
    Seconds(i64),
    Text(String),
}

impl std::fmt::Display for TimeText {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TimeText::Seconds(s) => write!(f, "{s}"),
            TimeText::Text(t) => write!(f, "{t:?}"),
        }
    }
}

impl From<&str> for TimeText {
    fn from(s: &str) -> Self {
        TimeText::Text(s.to_string())
    }
}

/// The calendar instant of mission time 0, for times written as year and day of year.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Epoch {
    /// Microseconds from 0001-001T00:00 (only differences are used).
    us_from_year_one: i64,
}

impl Default for Epoch {
    fn default() -> Self {
        parse_epoch(DEFAULT_EPOCH).expect("the default epoch parses")
    }
}

/// The epoch when a task network names none.
pub const DEFAULT_EPOCH: &str = "2028-040T00:00";

/// `yyyy-dddThh:mm[:ss]`, the epoch of a task network.
pub fn parse_epoch(text: &str) -> Result<Epoch, String> {
    day_of_year_time(text.trim())
        .ok_or_else(|| format!("{text:?} is not a year-day time like \"2028-040T00:00\""))?
        .map(|us| Epoch {
            us_from_year_one: us,
        })
}

/// `yyyy-dddThh:mm[:ss]` as µs from 0001-001; None if it does not look like one.
fn day_of_year_time(text: &str) -> Option<Result<i64, String>> {
    let (date, clock) = text.split_once('T')?;
    let (year, day) = date.split_once('-')?;
    let (year, day): (i64, i64) = (year.parse().ok()?, day.parse().ok()?);
    Some((|| {
        // Four digits at most: the arithmetic below stays far inside i64.
        if !(1..=9999).contains(&year) {
            return Err(format!("year {year} out of range 1..=9999 in {text:?}"));
        }
        if !(1..=366).contains(&day) {
            return Err(format!(
                "day of year {day} out of range 1..=366 in {text:?}"
            ));
        }
        let y = year - 1;
        let days_before = y * 365 + y / 4 - y / 100 + y / 400;
        Ok((days_before + day - 1) * DAY_US + clock_us(clock, text)? as i64)
    })())
}

/// `hh:mm[:ss[.ffffff]]` as µs into the day.
fn clock_us(clock: &str, whole: &str) -> Result<u64, String> {
    let parts: Vec<&str> = clock.split(':').collect();
    if !(2..=3).contains(&parts.len()) {
        return Err(format!(
            "{whole:?} is not a time: expected HH:MM, HH:MM:SS, DTHH:MM (D days after the epoch \
             day), YYYY-DDDTHH:MM or seconds"
        ));
    }
    let field = |s: &str, max: u64, what: &str| -> Result<u64, String> {
        let v: u64 = s
            .parse()
            .ok()
            .filter(|_| !s.is_empty() && s.len() <= 2)
            .ok_or_else(|| format!("bad {what} {s:?} in time {whole:?}"))?;
        if v >= max {
            return Err(format!(
                "{what} {v} out of range 0..{max} in time {whole:?}"
            ));
        }
        Ok(v)
    };
    let h = field(parts[0], 24, "hour")?;
    let m = field(parts[1], 60, "minute")?;
    let (s, frac_us) = match parts.get(2) {
        None => (0, 0),
        Some(sec) => match sec.split_once('.') {
            None => (field(sec, 60, "second")?, 0),
            Some((whole_s, frac)) => {
                if frac.is_empty() || frac.len() > 6 || !frac.bytes().all(|b| b.is_ascii_digit()) {
                    return Err(format!(
                        "bad fraction of a second {frac:?} in time {whole:?} (1 to 6 digits)"
                    ));
                }
                let scale = 10u64.pow(6 - frac.len() as u32);
                (
                    field(whole_s, 60, "second")?,
                    frac.parse::<u64>().unwrap_or(0) * scale,
                )
            }
        },
    };
    Ok(((h * 60 + m) * 60 + s) * SEC + frac_us)
}

/// Parse a mission time (see the module docs) against `epoch`.
pub fn parse_time(value: &TimeText, epoch: Epoch) -> Result<MissionTimeUs, String> {
    let text = match value {
        TimeText::Seconds(s) => {
            return u64::try_from(*s)
                .ok()
                .and_then(|s| s.checked_mul(SEC))
                .map(MissionTimeUs)
                .ok_or_else(|| format!("{s} s is not a mission time (0 to 2^44 s)"));
        }
        TimeText::Text(t) => t.trim(),
    };
    if let Some(abs) = day_of_year_time(text) {
        let us = abs? - epoch.us_from_year_one;
        return u64::try_from(us)
            .map(MissionTimeUs)
            .map_err(|_| format!("{text:?} is before the epoch"));
    }
    let (day, clock) = match text.split_once('T') {
        Some((day, clock)) => (
            day.parse::<u64>().map_err(|_| {
                format!("bad day {day:?} in time {text:?} (days after the epoch day)")
            })?,
            clock,
        ),
        None => (0, text),
    };
    let us = day
        .checked_mul(DAY_US as u64)
        .and_then(|d| d.checked_add(clock_us(clock, text).ok()?))
        .ok_or_else(|| match clock_us(clock, text) {
            Err(e) => e,
            Ok(_) => format!("{text:?} is too far after the epoch"),
        })?;
    Ok(MissionTimeUs(us))
}

/// Parse a duration (never negative) into microseconds.
pub fn parse_duration(value: &TimeText) -> Result<u64, String> {
    let us = parse_offset(value)?;
    u64::try_from(us).map_err(|_| format!("{value} is negative; a duration must not be"))
}

/// Parse a signed duration (an offset) into microseconds.
pub fn parse_offset(value: &TimeText) -> Result<i64, String> {
    let text = match value {
        TimeText::Seconds(s) => {
            return s
                .checked_mul(SEC as i64)
                .ok_or_else(|| format!("{s} s is too long a duration (at most 2^63 µs)"));
        }
        TimeText::Text(t) => t,
    };
    let compact: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    let (negative, body) = match compact.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, compact.as_str()),
    };
    if body.is_empty() {
        return Err(format!("{text:?} is not a duration: it is empty"));
    }
    let not_a_duration = || {
        format!(
            "{text:?} is not a duration (write e.g. \"15min\", \"90s\", \"1h30min\", \"250ms\" \
             or an integer number of seconds)"
        )
    };
    let total = if body.bytes().all(|b| b.is_ascii_digit()) {
        let n: i64 = body.parse().map_err(|_| too_long(text))?;
        n.checked_mul(SEC as i64).ok_or_else(|| too_long(text))?
    } else {
        let mut total: i64 = 0;
        let mut rest = body;
        while !rest.is_empty() {
            let digits = rest
                .find(|c: char| !c.is_ascii_digit())
                .unwrap_or(rest.len());
            if digits == 0 {
                return Err(not_a_duration());
            }
            let n: i64 = rest[..digits].parse().map_err(|_| too_long(text))?;
            rest = &rest[digits..];
            let unit_len = rest
                .find(|c: char| c.is_ascii_digit())
                .unwrap_or(rest.len());
            let scale: i64 = match &rest[..unit_len] {
                "us" | "µs" => 1,
                "ms" => 1_000,
                "s" | "sec" => SEC as i64,
                "m" | "min" => 60 * SEC as i64,
                "h" => 3_600 * SEC as i64,
                "d" => DAY_US,
                "" => {
                    return Err(format!(
                        "{text:?}: a number without a unit (us, ms, s, min, h, d)"
                    ))
                }
                unit => {
                    return Err(format!(
                        "{text:?}: unknown unit {unit:?} (use us, ms, s, min, h, d)"
                    ))
                }
            };
            rest = &rest[unit_len..];
            total = n
                .checked_mul(scale)
                .and_then(|v| total.checked_add(v))
                .ok_or_else(|| too_long(text))?;
        }
        total
    };
    Ok(if negative { -total } else { total })
}

fn too_long(text: &str) -> String {
    format!("{text:?} is too long a duration (at most about 292,000 years)")
}

/// `HH:MM:SS` (with `DT` after the epoch day, `.ffffff` when not whole seconds), for reports.
pub fn fmt_time(t: MissionTimeUs) -> String {
    let total_s = t.0 / SEC;
    let (day, rem) = (total_s / 86_400, total_s % 86_400);
    let (h, m, s) = (rem / 3600, rem % 3600 / 60, rem % 60);
    let frac = t.0 % SEC;
    let mut out = if day > 0 {
        format!("{day}T{h:02}:{m:02}:{s:02}")
    } else {
        format!("{h:02}:{m:02}:{s:02}")
    };
    if frac != 0 {
        out.push_str(&format!(".{frac:06}"));
    }
    out
}

/// A duration in the unit that reads best: `3 min`, `90 s`, `1.5 s`, `250 ms`, `62 µs`.
pub fn fmt_duration_us(us: u64) -> String {
    if us >= 60 * SEC && us.is_multiple_of(60 * SEC) {
        format!("{} min", us / (60 * SEC))
    } else if us >= SEC && us.is_multiple_of(SEC) {
        format!("{} s", us / SEC)
    } else if us >= SEC {
        format!("{:.1} s", us as f64 / SEC as f64)
    } else if us >= 1_000 {
        format!("{} ms", us / 1_000)
    } else {
        format!("{us} µs")
    }
}

/// A wall-clock duration for run errors ("timed out after 5.0 s").
pub fn fmt_wall(d: std::time::Duration) -> String {
    fmt_duration_us(u64::try_from(d.as_micros()).unwrap_or(u64::MAX))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(s: &str) -> Result<MissionTimeUs, String> {
        parse_time(&s.into(), Epoch::default())
    }

    fn d(s: &str) -> Result<u64, String> {
        parse_duration(&s.into())
    }

    #[test]
    fn every_time_form_parses() {
        assert_eq!(
            t("10:30").unwrap(),
            MissionTimeUs((10 * 3600 + 30 * 60) * SEC)
        );
        assert_eq!(t("00:00:15").unwrap(), MissionTimeUs(15 * SEC));
        assert_eq!(t("00:00:15.25").unwrap(), MissionTimeUs(15 * SEC + 250_000));
        assert_eq!(t("1T00:00").unwrap(), MissionTimeUs(86_400 * SEC));
        assert_eq!(t("2028-041T00:00").unwrap(), MissionTimeUs(86_400 * SEC));
        assert_eq!(t("2028-040T10:00").unwrap(), t("10:00").unwrap());
        assert_eq!(
            parse_time(&TimeText::Seconds(90), Epoch::default()).unwrap(),
            MissionTimeUs(90 * SEC)
        );
    }

    #[test]
    fn bad_times_say_what_is_wrong() {
        assert!(t("25:00").unwrap_err().contains("hour 25 out of range"));
        assert!(t("10").unwrap_err().contains("is not a time"));
        assert!(t("2028-039T23:00")
            .unwrap_err()
            .contains("before the epoch"));
        assert!(t("2028-400T00:00").unwrap_err().contains("day of year 400"));
        // Found by the tasknet_toml fuzz target: a huge year overflowed the day count.
        assert!(parse_epoch("2020000008-040T00:00")
            .unwrap_err()
            .contains("year 2020000008 out of range 1..=9999"));
        assert!(parse_epoch("0-040T00:00").unwrap_err().contains("year 0"));
        assert!(t("10000-001T00:00").unwrap_err().contains("year 10000"));
        assert!(t("xT10:00").unwrap_err().contains("bad day"));
        assert!(parse_time(&TimeText::Seconds(-1), Epoch::default()).is_err());
    }

    #[test]
    fn durations_parse_with_units_and_offsets_with_signs() {
        assert_eq!(d("3min").unwrap(), 180 * SEC);
        assert_eq!(d("15m").unwrap(), 900 * SEC);
        assert_eq!(d("15 min").unwrap(), 900 * SEC);
        assert_eq!(d("2h30min").unwrap(), 9000 * SEC);
        assert_eq!(d("1h30m").unwrap(), 5400 * SEC);
        assert_eq!(d("250ms").unwrap(), 250_000);
        assert_eq!(d("42").unwrap(), 42 * SEC);
        assert_eq!(parse_duration(&TimeText::Seconds(42)).unwrap(), 42 * SEC);
        assert_eq!(parse_offset(&"-30s".into()).unwrap(), -30_000_000);
        assert!(d("-30s").unwrap_err().contains("negative"));
    }

    #[test]
    fn a_too_long_duration_says_too_long_not_malformed() {
        let e = d("99999999999999999h").unwrap_err();
        assert!(e.contains("too long"), "{e}");
        let e = d("999999999999999999999").unwrap_err();
        assert!(e.contains("too long"), "{e}");
        let e = d("3 fortnights").unwrap_err();
        assert!(e.contains("unknown unit \"fortnights\""), "{e}");
        assert!(d("min").unwrap_err().contains("not a duration"));
        assert!(d("").unwrap_err().contains("empty"));
        assert!(d("15").is_ok());
        assert!(d("5 3").is_ok(), "spaces are ignored: 53 s");
    }

    #[test]
    fn times_format_back() {
        assert_eq!(fmt_time(t("10:30:05").unwrap()), "10:30:05");
        assert_eq!(fmt_time(t("2T10:00").unwrap()), "2T10:00:00");
        assert_eq!(fmt_time(t("00:00:01.5").unwrap()), "00:00:01.500000");
    }

    #[test]
    fn durations_format_in_a_readable_unit() {
        assert_eq!(fmt_duration_us(180 * SEC), "3 min");
        assert_eq!(fmt_duration_us(5 * SEC), "5 s");
        assert_eq!(fmt_duration_us(1_500_000), "1.5 s");
        assert_eq!(fmt_duration_us(62), "62 µs");
        assert_eq!(fmt_wall(std::time::Duration::from_secs(5)), "5 s");
    }
}
