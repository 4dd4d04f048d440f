//! Mission times and durations as scenario files write them.
//!
//! Times are relative to the task network's epoch (mission time 0): `"10:30"`, `"10:30:15"`,
//! `"1T10:30"` (day 1 after the epoch day). Durations: see below. Durations: `"3min"`, `"15 min"`, `"90s"`, `"1h"`, `"250ms"`,
//! `"2h30min"`, or an integer number of seconds.
use fsw_bridge::MissionTimeUs;

const SEC: u64 = 1_000_000;

/// Parse a mission time.
pub fn parse_time(text: &str) -> Result<MissionTimeUs, String> {
    let t = text.trim();
    let (day, clock) = match t.split_once('T') {
        Some((day, clock)) => (
            day.parse::<u64>()
                .map_err(|_| format!("bad day {day:?} in time {text:?}"))?,
            clock,
        ),
        None => (0, t),
    };
    let parts: Vec<&str> = clock.split(':').collect();
    if parts.len() < 2 || parts.len() > 3 {
        return Err(format!(
            "bad time {text:?}: expected HH:MM, HH:MM:SS or DTHH:MM (D: days after the epoch)"
        ));
    }
    let field = |s: &str, max: u64, what: &str| -> Result<u64, String> {
        let v: u64 = s
            .parse()
            .map_err(|_| format!("bad {what} {s:?} in time {text:?}"))?;
        if v >= max {
            return Err(format!("{what} {v} out of range in time {text:?}"));
        }
        Ok(v)
    };
    let h = field(parts[0], 24, "hour")?;
    let m = field(parts[1], 60, "minute")?;
    let s = if parts.len() == 3 {
        field(parts[2], 60, "second")?
    } else {
        0
    };
    Ok(MissionTimeUs(((day * 24 + h) * 3600 + m * 60 + s) * SEC))
}

/// Parse a duration into microseconds.
pub fn parse_duration(text: &str) -> Result<u64, String> {
    let t: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    if t.is_empty() {
        return Err("empty duration".into());
    }
    if let Ok(secs) = t.parse::<u64>() {
        return Ok(secs * SEC);
    }
    let mut total = 0u64;
    let mut rest = t.as_str();
    while !rest.is_empty() {
        let digits = rest
            .find(|c: char| !c.is_ascii_digit())
            .unwrap_or(rest.len());
        if digits == 0 {
            return Err(format!(
                "bad duration {text:?}: expected a number before {rest:?}"
            ));
        }
        let n: u64 = rest[..digits]
            .parse()
            .map_err(|_| format!("bad duration {text:?}"))?;
        rest = &rest[digits..];
        let unit_len = rest
            .find(|c: char| c.is_ascii_digit())
            .unwrap_or(rest.len());
        let unit = &rest[..unit_len];
        rest = &rest[unit_len..];
        let scale = match unit {
            "us" => 1,
            "ms" => 1_000,
            "s" | "sec" => SEC,
            "m" | "min" => 60 * SEC,
            "h" => 3600 * SEC,
            "d" => 86_400 * SEC,
            _ => {
                return Err(format!(
                    "bad duration {text:?}: unknown unit {unit:?} (use us, ms, s, min, h, d)"
                ))
            }
        };
        total = n
            .checked_mul(scale)
            .and_then(|v| total.checked_add(v))
            .ok_or_else(|| format!("duration {text:?} is too long"))?;
    }
    Ok(total)
}

/// `HH:MM:SS` (with `DT` when past the epoch day), for reports.
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_parse_in_all_forms() {
        assert_eq!(
            parse_time("10:30").unwrap(),
            MissionTimeUs((10 * 3600 + 30 * 60) * SEC)
        );
        assert_eq!(parse_time("00:00:15").unwrap(), MissionTimeUs(15 * SEC));
        assert_eq!(parse_time("1T00:00").unwrap(), MissionTimeUs(86_400 * SEC));
        assert!(parse_time("25:00").unwrap_err().contains("hour 25"));
        assert!(parse_time("10").is_err());
    }

    #[test]
    fn durations_parse_with_units() {
        assert_eq!(parse_duration("3min").unwrap(), 180 * SEC);
        assert_eq!(parse_duration("15 min").unwrap(), 900 * SEC);
        assert_eq!(parse_duration("2h30min").unwrap(), 9000 * SEC);
        assert_eq!(parse_duration("250ms").unwrap(), 250_000);
        assert_eq!(parse_duration("42").unwrap(), 42 * SEC);
        assert!(parse_duration("3 fortnights")
            .unwrap_err()
            .contains("unknown unit"));
        assert!(parse_duration("min").is_err());
    }

    #[test]
    fn times_format_back() {
        assert_eq!(fmt_time(parse_time("10:30:05").unwrap()), "10:30:05");
        assert_eq!(fmt_time(parse_time("2T10:00").unwrap()), "2T10:00:00");
    }
}
