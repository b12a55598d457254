//! What the suites share: medians, stage timings, peak memory.

use std::time::Instant;

/// The median of `v` (NaN when empty).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Milliseconds since `t`.
pub fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// max over channels of ‖a − b‖ / ‖b‖ (per channel over all entries).
pub fn relative_error(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    (0..3)
        .map(|c| {
            let num: f64 = a.iter().zip(b).map(|(x, y)| (x[c] - y[c]).powi(2)).sum();
            let den: f64 = b.iter().map(|y| y[c] * y[c]).sum();
            (num / den.max(f64::MIN_POSITIVE)).sqrt()
        })
        .fold(0.0, f64::max)
}

/// Peak resident memory of this process so far, or since the last [`reset_peak_rss`] (Linux
/// `VmHWM`), MiB.
pub fn peak_rss_mib() -> Option<f64> {
    status_mib("VmHWM:")
}

/// Resident memory of this process now (Linux `VmRSS`), MiB.
pub fn rss_mib() -> Option<f64> {
    status_mib("VmRSS:")
}

/// Starts the peak resident memory again from the present (Linux ≥ 4.0: `5` written to
/// `/proc/self/clear_refs`), so that one configuration's peak is not an earlier one's; whether
/// it could.
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

fn status_mib(field: &str) -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

#[cfg(test)]
mod tests {
    use super::median;

    #[test]
    fn the_peak_starts_again_at_a_reset() {
        let Some(before) = super::peak_rss_mib() else { return };
        let big = vec![1u8; 256 << 20];
        std::hint::black_box(&big);
        let peak = super::peak_rss_mib().unwrap();
        assert!(peak >= before.max(255.0), "peak {peak} MiB after touching 256 MiB");
        drop(big);
        if super::reset_peak_rss() {
            let now = super::rss_mib().unwrap();
            let reset = super::peak_rss_mib().unwrap();
            assert!(reset < peak - 128.0 && reset >= now - 1.0, "peak {reset} MiB after the reset, {now} MiB resident");
        }
    }

    #[test]
    fn median_of_odd_even_and_empty() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(Vec::new()).is_nan());
    }
}
