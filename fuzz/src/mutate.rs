//! A small mutation fuzzer on stable Rust, for machines without `cargo fuzz` (nightly and
//! libFuzzer): it takes the committed corpus of a target, mutates its files at random (byte
//! flips, insertions, deletions, duplicated and spliced ranges, numbers and separators that
//! readers treat specially) and runs the target's body on each mutant for a fixed time. A
//! panic is a finding; the input is written next to the test's other outputs.
//!
//! Included as a module by the `#[ignore]`d `fuzz_*_mutations` tests; they run for
//! `TRANSCUT_FUZZ_SECONDS` seconds per target (default 60).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The committed corpus of `target`: every file of `fuzz/corpus/<target>/`, sorted by name.
pub fn corpus(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus").join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files.into_iter().map(|p| (p.clone(), std::fs::read(&p).unwrap())).collect()
}

/// Seconds per target, from `TRANSCUT_FUZZ_SECONDS` (default 60).
pub fn seconds() -> u64 {
    std::env::var("TRANSCUT_FUZZ_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(60)
}

/// splitmix64: a small, seedable generator (the runs are reproducible from the seed).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

/// Tokens that readers treat specially.
const TOKENS: &[&[u8]] = &[
    b"\n",
    b"\r",
    b"\r\n",
    b" ",
    b"\\\n",
    b"#",
    b"/",
    b"//",
    b"-1",
    b"0",
    b"1",
    b"-0",
    b"4294967295",
    b"4294967296",
    b"2147483648",
    b"18446744073709551615",
    b"1e308",
    b"1e309",
    b"-1e308",
    b"nan",
    b"inf",
    b"NaN",
    b"3.0",
    b"1e-320",
    b"\xef\xbb\xbf",
    b"\0",
    b"\xff",
    b"end_header\n",
    b"element ",
    b"property list uchar int ",
    b"[",
    b"]",
    b"{",
    b"}",
    b"=",
    b"\"",
    b"[[object]]\n",
    b"[[light]]\n",
    b"[[edit]]\n",
    b"\x00\x00\x00\x80",
    b"\xff\xff\xff\x7f",
    b"\x00\x00\xc0\x7f",
];

/// One random mutation of `data`, with `other` (another corpus file) for splicing.
fn mutate(rng: &mut Rng, data: &mut Vec<u8>, other: &[u8]) {
    for _ in 0..1 + rng.below(4) {
        let len = data.len();
        match rng.below(8) {
            0 if len > 0 => {
                let i = rng.below(len);
                data[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                data[i] = rng.next() as u8;
            }
            2 => {
                let i = rng.below(len + 1);
                data.insert(i, rng.next() as u8);
            }
            3 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(64));
                data.drain(i..i + n);
            }
            4 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(256));
                let copy = data[i..i + n].to_vec();
                let at = rng.below(data.len() + 1);
                data.splice(at..at, copy);
            }
            5 => {
                let token = TOKENS[rng.below(TOKENS.len())];
                let at = rng.below(len + 1);
                if rng.below(2) == 0 || len == 0 {
                    data.splice(at..at, token.iter().copied());
                } else {
                    let end = (at + token.len()).min(len);
                    data.splice(at..end, token.iter().copied());
                }
            }
            6 if !other.is_empty() => {
                let i = rng.below(other.len());
                let n = 1 + rng.below((other.len() - i).min(512));
                let at = rng.below(len + 1);
                let end = (at + rng.below(n + 1)).min(len);
                data.splice(at..end, other[i..i + n].iter().copied());
            }
            _ => data.truncate(rng.below(len + 1)),
        }
    }
    data.truncate(1 << 20);
}

/// Runs `body` on mutants of `target`'s corpus for `seconds`; returns how many inputs ran.
///
/// # Panics
/// On the first input that makes `body` panic, after writing it to `out_dir`.
pub fn run<R>(target: &str, seconds: u64, out_dir: &Path, body: impl Fn(&[u8]) -> R) -> u64 {
    let seeds = corpus(target);
    assert!(!seeds.is_empty(), "no corpus for {target}");
    let mut rng = Rng(0x7472_616E_7363_7574 ^ target.len() as u64);
    let deadline = Instant::now() + Duration::from_secs(seconds);
    let mut runs = 0u64;
    // Panics are expected to be caught here: keep the default hook from printing each one.
    while Instant::now() < deadline {
        let (_, seed) = &seeds[rng.below(seeds.len())];
        let (_, other) = &seeds[rng.below(seeds.len())];
        let mut input = seed.clone();
        mutate(&mut rng, &mut input, other);
        if catch_unwind(AssertUnwindSafe(|| body(&input))).is_err() {
            std::fs::create_dir_all(out_dir).unwrap();
            let path = out_dir.join(format!("crash-{target}-{runs}"));
            std::fs::write(&path, &input).unwrap();
            panic!("{target}: input {runs} panicked; written to {}", path.display());
        }
        runs += 1;
    }
    runs
}
