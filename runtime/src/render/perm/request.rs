//! The `--cache`, `--qc` and `--qc-grad` options, checked before any GPU work.

use super::{formula, Counts, Quant, B_DB, B_GB, B_SB, DEFAULT_QC, MAX_BYTES};

/// The `--cache`, `--qc` and `--qc-grad` options, checked before any GPU
/// work: `None` for `--cache none`. The memory check here is the cache of
/// a single candidate cell (a lower bound); [`super::PermCache::build`] checks the
/// exact size once the candidates are known.
pub fn check_request(cache: &str, mode: &str, qc: Option<u32>, qc_grad: Option<u32>) -> Result<Option<Quant>, String> {
    match cache {
        "none" => {
            return match (qc, qc_grad) {
                (None, None) => Ok(None),
                _ => Err("--qc and --qc-grad size the PERM cache: add --cache perm (with --mode dvr)".into()),
            }
        }
        "perm" => {}
        other => return Err(format!("--cache {other}: unknown cache; use --cache none or --cache perm")),
    }
    if mode != "dvr" {
        return Err(format!(
            "--cache perm precomputes the values direct volume rendering samples; --mode {mode} has no such cache: add --mode dvr --tf ..., or drop --cache perm"
        ));
    }
    let n = qc.unwrap_or(DEFAULT_QC);
    let quant = Quant { density: n, gradient: qc_grad.unwrap_or(n) };
    for (flag, v) in [("--qc", quant.density), ("--qc-grad", quant.gradient)] {
        if v == 0 {
            return Err(format!(
                "{flag} 0: a cell needs at least one quantized position per axis; use 1 or more (the paper uses 5, and 3 for gradients)"
            ));
        }
    }
    let one = formula(&Counts { cells: 0, rows: 0, candidates: 1, quant }).total();
    if one > MAX_BYTES {
        let largest = (1..)
            .take_while(|&k| {
                formula(&Counts { cells: 0, rows: 0, candidates: 1, quant: Quant { density: k, gradient: k } }).total()
                    <= MAX_BYTES
            })
            .last()
            .unwrap_or(1);
        return Err(format!(
            "--qc {} --qc-grad {}: one candidate cell alone needs {one} bytes of PERM cache ({}^3 x {B_DB} + {}^3 x {}), over the limit of {MAX_BYTES} bytes; use --qc {largest} or less",
            quant.density,
            quant.gradient,
            quant.density,
            quant.gradient,
            3 * B_GB + B_SB
        ));
    }
    Ok(Some(quant))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_requests_are_refused_with_the_flag_named() {
        assert_eq!(check_request("none", "dvr", None, None), Ok(None));
        assert_eq!(check_request("perm", "dvr", None, None), Ok(Some(Quant { density: 5, gradient: 5 })));
        assert_eq!(check_request("perm", "dvr", Some(5), Some(3)), Ok(Some(Quant { density: 5, gradient: 3 })));
        for (cache, mode, qc, qg, fragment) in [
            ("perm", "dvr", Some(0), None, "--qc 0"),
            ("perm", "dvr", Some(4), Some(0), "--qc-grad 0"),
            ("perm", "dvr", Some(1000), None, "over the limit of 2147483648 bytes"),
            ("perm", "iso", None, None, "--mode iso"),
            ("lru", "dvr", None, None, "--cache lru"),
            ("none", "dvr", Some(5), None, "add --cache perm"),
        ] {
            let e = check_request(cache, mode, qc, qg).unwrap_err();
            assert!(e.contains(fragment) && !e.contains('\n'), "{e}");
        }
        // The refusal names the bytes: 1000^3 x 2 + 1000^3 x 4.
        assert!(check_request("perm", "dvr", Some(1000), None).unwrap_err().contains("6000000000 bytes"));
        // The largest accepted N is the one the message suggests.
        let e = check_request("perm", "dvr", Some(1000), None).unwrap_err();
        let largest: u32 = e.rsplit("--qc ").next().unwrap().split(' ').next().unwrap().parse().unwrap();
        assert!(check_request("perm", "dvr", Some(largest), None).is_ok());
        assert!(check_request("perm", "dvr", Some(largest + 1), None).is_err());
    }
}
