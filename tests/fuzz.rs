//! Mutation fuzzing of every parser, deterministic and under plain `cargo test` (cargo-fuzz
//! needs a nightly toolchain this project does not use). Each target starts from a seed
//! corpus of small valid inputs (`tests/fuzz/corpus/<target>/`), mutates them with a seeded
//! generator (bit flips, byte inserts and deletes, splices between seeds, truncation,
//! repeated or dropped lines, numbers swapped for extreme ones such as `1e300`, `NaN`,
//! `-0` or 2^64, pieces of each format's syntax spliced in, and extreme little-endian
//! integers, floats and varints in the binary formats) and
//! asks one thing of every input: the parser returns `Ok` or `Err`. It must not panic, must
//! not allocate far beyond the input's size and must not take long. Accepted stream frames
//! must also pose the fitted mask to finite positions, and accepted JSONL and binary (FWP2, FWP1) frames
//! must write back to text or bytes that read back equal.
//!
//! A failing input is written to `tests/fuzz/crashes/<target>/` and reported in hex;
//! once fixed it moves to the corpus as `crash-*`, a permanent regression input. Corpus
//! files not named `crash-*` must parse (the seeds stay valid).
//!
//! `FACEWIRE_FUZZ_ITERS` (default 2,000 per target: a quick pass for `cargo test` at a
//! desk; `.ci/run` sets 50,000) and `FACEWIRE_FUZZ_SEED` (default 1) make longer or
//! different runs: `FACEWIRE_FUZZ_ITERS=200000 cargo test --test fuzz`.

mod common;

use common::{data, repo_path};

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::{Cell, RefCell};
use std::fmt::Write as _;
use std::io::Cursor;
use std::panic::{self, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::{Once, OnceLock};
use std::time::{Duration, Instant};

use facewire::fit::{FitFile, FittedMask, Landmarks};
use facewire::head::Head;
use facewire::mask::{FapuValues, Mask};
use facewire::stream::{
    ArkitBasis, AuTextOptions, AuTextReader, FapReader, Frame, FramePoser, JsonlReader, JsonlWriter,
    StreamError,
};
use facewire_proto::audio_chunk::AudioChunk;
use facewire_proto::param_frame::{ParamFrame, ParamViseme};

/// Generous guard against inputs that make a parser crawl, in CPU time of the thread; the
/// real inputs take microseconds to a millisecond.
const TIME_BUDGET: Duration = Duration::from_secs(2);
/// Bytes one input may have allocated at its peak beyond what the harness holds: a fixed
/// allowance plus a multiple of its length (a deflate stream may inflate about 1000-fold).
const ALLOC_BASE: usize = 32 << 20;
const ALLOC_PER_INPUT_BYTE: usize = 1100;
/// A single thread above this while fuzzing is stopped at once (the input is saved first).
const ALLOC_CAP: usize = 1 << 30;

// ---------------------------------------------------------------- allocation accounting

struct Accounting;

thread_local! {
    /// Bytes this thread holds, and its peak since the last reset.
    static LIVE: Cell<usize> = const { Cell::new(0) };
    static PEAK: Cell<usize> = const { Cell::new(0) };
    /// Set while this thread runs a parser on a fuzz input.
    static FUZZING: Cell<bool> = const { Cell::new(false) };
    /// The input being run and its target, for the report when it panics or over-allocates.
    static CURRENT: RefCell<(String, Vec<u8>)> = const { RefCell::new((String::new(), Vec::new())) };
    static PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

unsafe impl GlobalAlloc for Accounting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let live = LIVE
            .try_with(Cell::get)
            .unwrap_or(0)
            .saturating_add(layout.size());
        if live > ALLOC_CAP && FUZZING.try_with(Cell::get).unwrap_or(false) {
            over_cap(layout.size());
            return std::ptr::null_mut();
        }
        let ptr = unsafe { System.alloc(layout) };
        if !ptr.is_null() {
            let _ = LIVE.try_with(|l| l.set(live));
            let _ = PEAK.try_with(|p| p.set(p.get().max(live)));
        }
        ptr
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        let _ = LIVE.try_with(|l| l.set(l.get().saturating_sub(layout.size())));
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Accounting = Accounting;

/// Called by the allocator when a fuzz input asks for more than [`ALLOC_CAP`]: saves the
/// input and says so before the allocation fails (which aborts the process).
fn over_cap(size: usize) {
    FUZZING.with(|f| f.set(false));
    CURRENT.with(|current| {
        let (target, input) = &*current.borrow();
        let saved = save_crash(target, input);
        eprintln!(
            "fuzz {target}: an input asked for {size} bytes with {} held; saved as {}\n{}",
            LIVE.with(Cell::get),
            saved.display(),
            hex(input)
        );
    });
}

// ---------------------------------------------------------------- generator

/// SplitMix64: small, fast and the same everywhere.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n`; `n` must be positive.
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    fn chance(&mut self, one_in: usize) -> bool {
        self.below(one_in) == 0
    }
}

/// Numbers that break parsers: out of every type's range, not finite, signed zero, odd syntax.
const NUMBERS: [&str; 34] = [
    "0",
    "-0",
    "-0.0",
    "1",
    "-1",
    "0.5",
    "1e300",
    "-1e300",
    "1e-300",
    "1e39",
    "-1e39",
    "3.4e38",
    "-3.4e38",
    "1e10",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "infinity",
    "255",
    "256",
    "65535",
    "65536",
    "4294967296",
    "9007199254740993",
    "9223372036854775807",
    "-9223372036854775808",
    "18446744073709551615",
    "18446744073709551616",
    "1e",
    ".",
    "0x10",
    "1_000",
    "",
];

/// Pieces of the text formats' syntax, spliced in whole: JSON values and keys, TOML
/// tables, OBJ records, `.fap` and AU text headers.
const TOKENS: [&str; 30] = [
    "{}",
    "[]",
    "null",
    "true",
    "\"\"",
    "[[[[",
    "}}}}",
    "\"seq\":1,",
    "\"t\":0,",
    "\"au\":{\"jaw_drop\":",
    "\"fap\":{\"1\":",
    "\"arkit\":{\"52\":",
    "\"controls\":[",
    "\"viseme\":",
    "\"label\":",
    "\\u0000",
    "\\ud800",
    "# columns: time ",
    "# VERTEX LIST:\n",
    "# ANIMATION UNITS LIST:\n",
    "[[nudge]]\n",
    "[[landmark]]\n",
    " = ",
    "v 0 0 0\n",
    "f 1 2 3\n",
    "f -1 -2 -3\n",
    "1 ",
    "0 ",
    "\r\n",
    "2.1 x 25 1\n",
];

/// Little-endian values of every width that hit the edges of binary fields.
fn binary_value(rng: &mut Rng) -> Vec<u8> {
    match rng.below(6) {
        // LEB128 varints: i64::MAX, 2^63, u64::MAX, one byte too long.
        5 => match rng.below(4) {
            0 => [[0xffu8; 8].as_slice(), &[0x7f]].concat(),
            1 => [[0x80u8; 9].as_slice(), &[0x01]].concat(),
            2 => [[0xffu8; 9].as_slice(), &[0x01]].concat(),
            _ => vec![0xff; 11],
        },
        0 => vec![[0u8, 1, 2, 3, 0x7f, 0x80, 0xfe, 0xff][rng.below(8)]],
        1 => [0u16, 1, 52, 65, 68, 69, 255, 256, 0x7fff, 0x8000, 0xffff][rng.below(11)]
            .to_le_bytes()
            .to_vec(),
        2 => [0u32, 1, 113, 0x7fff_ffff, 0x8000_0000, 0xffff_ffff][rng.below(6)]
            .to_le_bytes()
            .to_vec(),
        3 => [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            -f32::MAX,
            -0.0,
            f32::MIN_POSITIVE,
            1e-45,
            11.0,
            1e6,
        ][rng.below(10)]
        .to_le_bytes()
        .to_vec(),
        _ => match rng.below(3) {
            0 => [0u64, u64::MAX, 1 << 53, 1 << 63][rng.below(4)]
                .to_le_bytes()
                .to_vec(),
            _ => [f64::NAN, f64::INFINITY, 1e300, -1.0, 1e10 + 1.0, f64::MAX][rng.below(6)]
                .to_le_bytes()
                .to_vec(),
        },
    }
}

/// Spans of `text` that look like numbers (digits, signs, points, exponents).
fn number_spans(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let starts = bytes[i].is_ascii_digit()
            || (bytes[i] == b'-' && bytes.get(i + 1).is_some_and(u8::is_ascii_digit));
        if !starts {
            i += 1;
            continue;
        }
        let start = i;
        i += 1;
        while i < bytes.len() && matches!(bytes[i], b'0'..=b'9' | b'.' | b'e' | b'E' | b'+' | b'-') {
            i += 1;
        }
        spans.push((start, i));
    }
    spans
}

/// Byte ranges of the lines of `bytes`, terminators included.
fn line_spans(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut start = 0;
    for (i, &b) in bytes.iter().enumerate() {
        if b == b'\n' {
            spans.push((start, i + 1));
            start = i + 1;
        }
    }
    if start < bytes.len() {
        spans.push((start, bytes.len()));
    }
    spans
}

/// A random range of `len` bytes (maybe empty).
fn range(rng: &mut Rng, len: usize) -> (usize, usize) {
    let start = rng.below(len + 1);
    let end = start + rng.below((len - start).min(64) + 1);
    (start, end)
}

/// Applies one to four random mutations to `input`; `seeds` provide splices.
fn mutate(rng: &mut Rng, input: &mut Vec<u8>, seeds: &[Vec<u8>], binary: bool, max_len: usize) {
    for _ in 0..1 + rng.below(4) {
        let len = input.len();
        match rng.below(13) {
            0 if len > 0 => {
                let at = rng.below(len);
                input[at] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let at = rng.below(len);
                let alphabet = b" \n\r\t#-+.e0129\"{}[],:/\\\x00\xff\xc3";
                input[at] = alphabet[rng.below(alphabet.len())];
            }
            2 => {
                let at = rng.below(len + 1);
                let byte = rng.next() as u8;
                input.insert(at, byte);
            }
            3 => {
                let (start, end) = range(rng, len);
                input.drain(start..end);
            }
            4 => {
                let (start, end) = range(rng, len);
                let chunk = input[start..end].to_vec();
                let copies = if rng.chance(8) { 1 + rng.below(200) } else { 1 };
                for _ in 0..copies {
                    input.splice(end..end, chunk.iter().copied());
                }
            }
            5 => {
                let other = &seeds[rng.below(seeds.len())];
                let (from, to) = range(rng, other.len());
                let (start, end) = range(rng, len);
                input.splice(start..end, other[from..to].iter().copied());
            }
            6 => input.truncate(rng.below(len + 1)),
            12 if !binary => {
                let (start, end) = range(rng, len);
                let end = if rng.chance(2) { start } else { end };
                input.splice(start..end, TOKENS[rng.below(TOKENS.len())].bytes());
            }
            7 if binary => {
                let value = binary_value(rng);
                let at = rng.below(len + 1);
                let end = (at + value.len()).min(len);
                input.splice(at..end, value);
            }
            7 | 8 => {
                let spans = number_spans(input);
                if !spans.is_empty() {
                    let (start, end) = spans[rng.below(spans.len())];
                    input.splice(start..end, NUMBERS[rng.below(NUMBERS.len())].bytes());
                }
            }
            9 => {
                let lines = line_spans(input);
                if !lines.is_empty() {
                    let (start, end) = lines[rng.below(lines.len())];
                    let line = input[start..end].to_vec();
                    let copies = if rng.chance(4) { 1 + rng.below(50) } else { 1 };
                    for _ in 0..copies {
                        input.splice(end..end, line.iter().copied());
                    }
                }
            }
            10 => {
                let lines = line_spans(input);
                if !lines.is_empty() {
                    let (start, end) = lines[rng.below(lines.len())];
                    input.drain(start..end);
                }
            }
            _ => {
                let lines = line_spans(input);
                if lines.len() >= 2 {
                    let a = lines[rng.below(lines.len())];
                    let b = lines[rng.below(lines.len())];
                    let (first, second) = if a.0 <= b.0 { (a, b) } else { (b, a) };
                    if first.1 <= second.0 {
                        let mut swapped = input[..first.0].to_vec();
                        swapped.extend_from_slice(&input[second.0..second.1]);
                        swapped.extend_from_slice(&input[first.1..second.0]);
                        swapped.extend_from_slice(&input[first.0..first.1]);
                        swapped.extend_from_slice(&input[second.1..]);
                        *input = swapped;
                    }
                }
            }
        }
        input.truncate(max_len);
    }
}

// ---------------------------------------------------------------- harness

fn fuzz_dir() -> PathBuf {
    repo_path("tests/fuzz")
}

fn env_number(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(default)
}

fn hex(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len() * 3);
    for (i, b) in bytes.iter().enumerate().take(4096) {
        let _ = write!(out, "{b:02x}{}", if i % 32 == 31 { "\n" } else { " " });
    }
    if bytes.len() > 4096 {
        let _ = write!(out, "... ({} bytes)", bytes.len());
    }
    out
}

/// FNV-1a, to name saved inputs by their content.
fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

fn save_crash(target: &str, input: &[u8]) -> PathBuf {
    let dir = fuzz_dir().join("crashes").join(target);
    let path = dir.join(format!("crash-{:016x}", fnv(input)));
    let _ = std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(&path, input));
    path
}

fn install_panic_hook() {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let default = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if FUZZING.with(Cell::get) {
                PANIC.with(|p| *p.borrow_mut() = Some(info.to_string()));
            } else {
                default(info);
            }
        }));
    });
}

/// CPU time this thread has used: unlike the wall clock, it does not count the time other
/// tests or other builds on the machine take the cores.
fn thread_cpu_time() -> Duration {
    let mut now = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec, which `now` is.
    let status = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut now) };
    assert_eq!(status, 0, "no thread CPU clock");
    Duration::new(now.tv_sec as u64, now.tv_nsec as u32)
}

/// What one input did wrong.
enum Failure {
    Panic(String),
    Slow(Duration),
    Memory(usize),
}

/// Runs `parse` on one input, catching panics and measuring time and peak memory.
fn run_one(target: &str, input: &[u8], parse: fn(&[u8]) -> bool) -> Result<bool, Failure> {
    CURRENT.with(|c| {
        let mut current = c.borrow_mut();
        current.0.clear();
        current.0.push_str(target);
        current.1.clear();
        current.1.extend_from_slice(input);
    });
    let held = LIVE.with(Cell::get);
    PEAK.with(|p| p.set(held));
    let started = thread_cpu_time();
    FUZZING.with(|f| f.set(true));
    let result = panic::catch_unwind(AssertUnwindSafe(|| parse(input)));
    FUZZING.with(|f| f.set(false));
    let elapsed = thread_cpu_time().saturating_sub(started);
    let peak = PEAK.with(Cell::get).saturating_sub(held);
    match result {
        Err(_) => Err(Failure::Panic(
            PANIC.with(|p| p.borrow_mut().take()).unwrap_or_default(),
        )),
        Ok(_) if elapsed > TIME_BUDGET => Err(Failure::Slow(elapsed)),
        Ok(_) if peak > ALLOC_BASE + ALLOC_PER_INPUT_BYTE * input.len() => Err(Failure::Memory(peak)),
        Ok(parsed) => Ok(parsed),
    }
}

/// Runs the corpus of `target`, then mutated inputs, and fails listing every bad input.
fn fuzz(target: &str, max_len: usize, binary: bool, parse: fn(&[u8]) -> bool) {
    install_panic_hook();
    let dir = fuzz_dir().join("corpus").join(target);
    let mut entries: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    let mut seeds = Vec::new();
    let mut problems = Vec::new();
    for path in &entries {
        let input = std::fs::read(path).unwrap();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        match run_one(target, &input, parse) {
            Ok(parsed) if !parsed && !name.starts_with("crash-") => {
                problems.push(format!("seed {name} does not parse"))
            }
            Ok(_) => {}
            Err(failure) => problems.push(describe(target, &name, &input, failure)),
        }
        if !name.starts_with("crash-") {
            seeds.push(input);
        }
    }
    assert!(!seeds.is_empty(), "{}: no seeds", dir.display());

    let iterations = env_number("FACEWIRE_FUZZ_ITERS", 2000);
    let mut rng = Rng(env_number("FACEWIRE_FUZZ_SEED", 1) ^ fnv(target.as_bytes()));
    let started = Instant::now();
    let mut accepted = 0;
    for iteration in 0..iterations {
        let mut input = seeds[rng.below(seeds.len())].clone();
        mutate(&mut rng, &mut input, &seeds, binary, max_len);
        match run_one(target, &input, parse) {
            Ok(parsed) => accepted += usize::from(parsed),
            Err(failure) => {
                problems.push(describe(
                    target,
                    &format!("iteration {iteration}"),
                    &input,
                    failure,
                ));
                if problems.len() >= 10 {
                    break;
                }
            }
        }
    }
    eprintln!(
        "fuzz {target}: {iterations} inputs ({accepted} accepted) in {:.2} s",
        started.elapsed().as_secs_f64()
    );
    assert!(problems.is_empty(), "fuzz {target}:\n{}", problems.join("\n"));
}

fn describe(target: &str, what: &str, input: &[u8], failure: Failure) -> String {
    let problem = match failure {
        Failure::Panic(message) => format!("panicked ({message})"),
        Failure::Slow(elapsed) => format!("took {:.2} s", elapsed.as_secs_f64()),
        Failure::Memory(peak) => format!("allocated {peak} bytes at its peak"),
    };
    let saved = save_crash(target, input);
    format!(
        "{what}: {problem}; saved as {}\ninput ({} bytes): {:?}\n{}",
        saved.display(),
        input.len(),
        String::from_utf8_lossy(&input[..input.len().min(300)]),
        hex(input)
    )
}

// ---------------------------------------------------------------- targets

/// CANDIDE-3, parsed once for all the targets that need it.
fn candide3() -> &'static Mask {
    static MASK: OnceLock<Mask> = OnceLock::new();
    MASK.get_or_init(Mask::candide3)
}

/// The shipped MakeHuman fit of CANDIDE-3 and the ARKit basis, to pose accepted frames.
fn fitted() -> &'static (FittedMask, ArkitBasis) {
    static FITTED: OnceLock<(FittedMask, ArkitBasis)> = OnceLock::new();
    FITTED.get_or_init(|| {
        let path = data("heads/makehuman_head.fit.toml");
        let fit = FitFile::load(&path).unwrap().resolve("fit", candide3()).unwrap();
        (FittedMask::new(candide3().clone(), fit), ArkitBasis::shipped())
    })
}

/// What the service does with an accepted frame: it poses the fitted mask, which must stay
/// finite (the frame bounds exist for this).
fn pose(frame: &Frame) {
    let (fitted, basis) = fitted();
    let mut poser = FramePoser::new(fitted);
    let posed = poser.pose(fitted, basis, frame);
    assert!(
        posed.iter().all(|p| p.is_finite()) && frame.head_rotation().iter().all(|r| r.is_finite()),
        "an accepted frame poses the mask off to infinity: {frame:?}"
    );
}

/// An accepted JSONL frame is written back by `JsonlWriter` and reads back equal.
fn jsonl_round_trip(frame: &Frame) {
    let mask = candide3();
    let mut writer = JsonlWriter::new(Vec::new(), mask);
    writer
        .write_frame(frame)
        .expect("the writer takes what the reader accepts");
    let line = String::from_utf8(writer.into_inner().unwrap()).unwrap();
    let back = facewire::stream::jsonl::parse_message("written", line.trim_end(), mask).unwrap();
    assert_eq!(&back, frame, "{line}");
}

/// An accepted binary frame encodes back, as FWP2 and (when it can carry it) as FWP1, to a
/// message that is accepted as the same frame.
fn param_frame_round_trip(frame: &Frame) {
    let p = ParamFrame {
        seq: frame.seq,
        time_s: frame.time_s,
        animation: frame.animation.clone(),
        faps: frame.faps.clone(),
        arkit: frame.arkit.clone(),
        head_rotation_rad: frame.head_rotation_rad,
        head_translation: frame.head_translation,
        label: frame.label.clone(),
        viseme: frame.viseme.map(|v| ParamViseme::Fap1 {
            select1: v.select1 as u8,
            select2: v.select2 as u8,
            blend: v.blend as u8,
            definition: v.definition as u8,
        }),
        ignored: Vec::new(),
    };
    let back = ParamFrame::decode(&p.encode()).unwrap();
    assert_eq!(&Frame::from_param_frame(back, candide3()).unwrap(), frame);
    if let Ok(fwp1) = p.encode_fwp1() {
        let back = ParamFrame::decode(&fwp1).unwrap();
        assert_eq!(&Frame::from_param_frame(back, candide3()).unwrap(), frame);
    }
}

/// Reads a whole stream, posing every frame; returns whether every frame was read.
fn drain(frames: impl Iterator<Item = Result<Frame, StreamError>>) -> bool {
    let mut ok = true;
    for frame in frames {
        match frame {
            Ok(frame) => pose(&frame),
            Err(_) => ok = false,
        }
    }
    ok
}

#[test]
fn wfm() {
    // With what `facewire inspect MASK.wfm` and every fit do next with a mask.
    fuzz("wfm", 64 << 10, false, |bytes| {
        Mask::from_wfm_bytes(bytes).is_ok_and(|mask| {
            FapuValues::measure(&mask.vertices);
            mask.used_vertices();
            true
        })
    });
}

#[test]
fn obj() {
    // Kept under 2 KB: many repeated faces are still quadratic in the head checks.
    fuzz("obj", 2 << 10, false, |bytes| {
        Head::from_obj_bytes("fuzz.obj", bytes).is_ok()
    });
}

#[test]
fn fit_toml() {
    fuzz("fit_toml", 16 << 10, false, |bytes| {
        let mask = candide3();
        let text = String::from_utf8_lossy(bytes);
        FitFile::parse("fuzz.fit.toml", &text).is_ok_and(|file| file.resolve("fuzz", mask).is_ok())
    });
}

#[test]
fn landmarks_toml() {
    // What `Landmarks::load` does after reading the file, then the checks `facewire fit` runs.
    fuzz("landmarks_toml", 16 << 10, false, |bytes| {
        let text = String::from_utf8_lossy(bytes);
        Landmarks::parse("fuzz", &text).is_ok_and(|l| l.validate("fuzz", 113, 8_800).is_ok())
    });
}

#[test]
fn jsonl() {
    fuzz("jsonl", 64 << 10, false, |bytes| {
        let mask = candide3();
        let lines_ok = String::from_utf8_lossy(bytes)
            .lines()
            .filter(|line| !line.trim().is_empty())
            .all(|line| {
                facewire::stream::jsonl::parse_message("fuzz", line, mask)
                    .inspect(pose)
                    .inspect(jsonl_round_trip)
                    .is_ok()
            });
        drain(JsonlReader::new(bytes, mask)) && lines_ok
    });
}

#[test]
fn fap() {
    fuzz("fap", 64 << 10, false, |bytes| drain(FapReader::new(bytes)));
}

#[test]
fn au_text() {
    fuzz("au_text", 64 << 10, false, |bytes| {
        let mask = candide3();
        let timed = AuTextOptions {
            fps: 25.0,
            headerless_time_column: true,
        };
        let plain = AuTextReader::new(Cursor::new(bytes), mask, AuTextOptions::default()).is_ok_and(drain);
        let timed = AuTextReader::new(Cursor::new(bytes), mask, timed).is_ok_and(drain);
        plain || timed
    });
}

#[test]
fn param_frame() {
    fuzz("param_frame", 4 << 10, true, |bytes| {
        ParamFrame::decode(bytes).is_ok_and(|p| {
            Frame::from_param_frame(p, candide3())
                .inspect(pose)
                .inspect(param_frame_round_trip)
                .is_ok()
        })
    });
}

#[test]
fn audio_chunk() {
    fuzz("audio_chunk", 4 << 10, true, |bytes| {
        AudioChunk::decode(bytes).is_ok_and(|chunk| {
            // What the server does next: time the chunk, encode it for its viewers, and
            // that encoding reads back as the same chunk.
            let _ = chunk.body.samples();
            let back = AudioChunk::decode(&chunk.encode()).expect("an accepted chunk encodes back");
            assert_eq!((back.t_s, &back.body), (chunk.t_s, &chunk.body));
            true
        })
    });
}

#[test]
fn ogg_opus() {
    fuzz("ogg_opus", 8 << 10, true, |bytes| {
        // As mutated, where nearly every change breaks a page's checksum; then with every
        // page's checksum made right again, so that the mutations reach the packets.
        let raw = facewire::voice::read_ogg_opus(bytes, "fuzz.opus");
        let resealed = facewire::voice::read_ogg_opus(&with_ogg_checksums(bytes), "fuzz.opus");
        for file in [&raw, &resealed].into_iter().flatten() {
            // What the service does next: bound the length before decoding.
            assert!(!file.packets.is_empty() && file.duration_s().is_finite());
        }
        raw.is_ok()
    });
}

#[test]
fn glb() {
    fuzz("glb", 4 << 10, true, |bytes| {
        // As mutated, where a changed length breaks the container; then with the JSON and
        // binary chunks packed again around what the mutations made of them, so that
        // they reach the accessors, nodes and skins.
        let raw = facewire::head::read_glb(bytes);
        if let Some((json, bin)) = glb_chunks(bytes) {
            if let Ok(meshes) = facewire::head::read_glb(&common::glb::pack(json, bin)) {
                // What a registration does next: tell the skin from the parts.
                let _ = facewire::head::glb_head(meshes, &[]);
            }
        }
        raw.is_ok()
    });
}

/// A GLB's JSON chunk (from after its header to the binary chunk's header, however long
/// the header says it is) and binary chunk (the rest).
fn glb_chunks(bytes: &[u8]) -> Option<(&[u8], &[u8])> {
    let body = bytes.get(20..)?;
    let bin = body.windows(4).position(|w| w == b"BIN\0")?;
    Some((&body[..bin.checked_sub(4)?], &body[bin + 4..]))
}

#[test]
fn ogg_checksums_are_resealed_as_an_encoder_wrote_them() {
    let file = std::fs::read(repo_path("tests/voices/syllables_2s.opus")).unwrap();
    assert_eq!(with_ogg_checksums(&file), file);
    let mut changed = file.clone();
    changed[100] ^= 0x20;
    assert!(facewire::voice::read_ogg_opus(&changed, "x").is_err());
    assert_ne!(with_ogg_checksums(&changed), changed);
}

/// `bytes` with the CRC of every Ogg page it starts with set right (CRC-32, polynomial
/// 0x04c11db7, unreflected, as RFC 3533 defines it), as far as its pages are whole.
fn with_ogg_checksums(bytes: &[u8]) -> Vec<u8> {
    let crc = |data: &[u8]| {
        data.iter().fold(0u32, |mut crc, &byte| {
            crc ^= u32::from(byte) << 24;
            for _ in 0..8 {
                crc = if crc & 0x8000_0000 != 0 {
                    (crc << 1) ^ 0x04c1_1db7
                } else {
                    crc << 1
                };
            }
            crc
        })
    };
    let mut out = bytes.to_vec();
    let mut at = 0;
    while out.len() >= at + 27 && out[at..].starts_with(b"OggS") {
        let segments = usize::from(out[at + 26]);
        let Some(table) = out.get(at + 27..at + 27 + segments) else {
            break;
        };
        let end = at + 27 + segments + table.iter().map(|&s| usize::from(s)).sum::<usize>();
        if end > out.len() {
            break;
        }
        out[at + 22..at + 26].fill(0);
        let sum = crc(&out[at..end]);
        out[at + 22..at + 26].copy_from_slice(&sum.to_le_bytes());
        at = end;
    }
    out
}

#[test]
fn viewer_frame() {
    fuzz(
        "viewer_frame",
        16 << 10,
        true,
        |bytes| match facewire_proto::viewer_frame::decode(bytes) {
            Ok(frame) => {
                // What a viewer does next: apply the deltas to its rest mesh.
                if frame.vertex_count <= 100_000 {
                    let rest = vec![0.0f32; frame.vertex_count as usize * 3];
                    let mut out = Vec::new();
                    frame.apply(&rest, &mut out);
                }
                true
            }
            Err(_) => false,
        },
    );
}

#[test]
fn the_harness_catches_panics_and_wild_allocations() {
    install_panic_hook();
    assert!(matches!(run_one("self-test", b"ok", |_| true), Ok(true)));
    match run_one("self-test", b"x", |bytes| bytes[5] == 0) {
        Err(Failure::Panic(message)) => assert!(message.contains("index out of bounds"), "{message}"),
        _ => panic!("a panic was not caught"),
    }
    let wild = |_: &[u8]| std::hint::black_box(vec![1u8; 100 << 20]).len() > 1;
    assert!(matches!(run_one("self-test", b"x", wild), Err(Failure::Memory(peak)) if peak >= 100 << 20));
}
