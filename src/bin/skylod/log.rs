//! Messages and progress on standard error: `--quiet`, `--log-level`, and the
//! [`skylod::runtime::progress::Progress`] of the library drawn as `indicatif` bars on a terminal or
//! written as plain lines otherwise.
//!
//! Levels: errors always (also with `--quiet`); warnings and the summary lines (one per
//! output written, the closing line of a command) by default; `info` adds one line per
//! stage and per file read or written (the plain-text progress), `debug` a line per tenth of
//! the POIs. Bars (files, bytes, POIs, ETA) are drawn only when standard error is a
//! terminal and `--quiet` is not given; a stage without a count shows a spinner, so no long
//! step is silent.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use skylod::runtime::progress::{Progress, Stage};
use std::collections::HashMap;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

/// How much is said on standard error.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Errors only.
    Error,
    /// Warnings and the summary lines (the default).
    Warn,
    /// Also one line per stage and per file (progress as text).
    Info,
    /// Also the POIs done, by tenths.
    Debug,
}

/// `--quiet`, `--log-level`: on every command (`global`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct LogArgs {
    /// Say nothing on standard error but errors (no progress, no warnings, no summary).
    #[arg(long, short = 'q', global = true)]
    pub quiet: bool,
    /// What is written on standard error: error, warn (warnings and the summary lines),
    /// info (also a line per stage and per file: progress when standard error is not a
    /// terminal), debug. Progress bars are drawn on a terminal whatever the level.
    #[arg(
        long,
        global = true,
        value_enum,
        value_name = "LEVEL",
        default_value = "warn"
    )]
    pub log_level: Level,
}

struct Logger {
    level: Level,
    quiet: bool,
    bars: Option<MultiProgress>,
}

static LOGGER: OnceLock<Logger> = OnceLock::new();

/// Set by the first SIGINT (Ctrl-C), SIGTERM or SIGHUP: the library's long loops stop at
/// their next item ([`Progress::is_cancelled`]), outputs not yet renamed into place are removed.
static INTERRUPTED: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// The number of the last of those signals received (0: none).
static SIGNAL: OnceLock<Arc<AtomicUsize>> = OnceLock::new();

fn interrupted() -> &'static Arc<AtomicBool> {
    INTERRUPTED.get_or_init(|| Arc::new(AtomicBool::new(false)))
}

/// SIGINT (Ctrl-C), SIGTERM and SIGHUP ask the running command to stop at its next file or
/// POI, so that no partial or temporary file is left behind; a second one ends the process at
/// once (exit 2 after Ctrl-C, 128 + the signal's number otherwise).
pub fn on_interrupt() {
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        use signal_hook::flag;
        let signal = SIGNAL.get_or_init(|| Arc::new(AtomicUsize::new(0)));
        for sig in [SIGINT, SIGTERM, SIGHUP] {
            let second = if sig == SIGINT { 2 } else { 128 + sig };
            // Registered first: it runs before the flag is set, so only on the second signal.
            let _ = flag::register_conditional_shutdown(sig, second, Arc::clone(interrupted()));
            let _ = flag::register_usize(sig, Arc::clone(signal), sig as usize);
            let _ = flag::register(sig, Arc::clone(interrupted()));
        }
    }
}

/// The exit code a command stopped by a signal ends with: 128 + the signal's number for
/// SIGTERM (143) and SIGHUP (129), as a shell reports a process the signal killed; `None` when
/// no signal came or it was Ctrl-C (whose cancellation is a fatal error, exit 2).
pub fn signal_exit_code() -> Option<u8> {
    let sig = SIGNAL.get()?.load(Ordering::SeqCst);
    #[cfg(unix)]
    if sig != 0 && sig != signal_hook::consts::SIGINT as usize {
        return u8::try_from(128 + sig).ok();
    }
    let _ = sig;
    None
}

/// Set up messages and progress from the global flags (once, before any command runs).
pub fn init(args: &LogArgs) {
    let tty = std::io::stderr().is_terminal();
    let bars =
        (tty && !args.quiet).then(|| MultiProgress::with_draw_target(ProgressDrawTarget::stderr()));
    let _ = LOGGER.set(Logger {
        level: if args.quiet {
            Level::Error
        } else {
            args.log_level
        },
        quiet: args.quiet,
        bars,
    });
}

fn logger() -> &'static Logger {
    LOGGER.get_or_init(|| Logger {
        level: Level::Warn,
        quiet: false,
        bars: None,
    })
}

/// Whether messages of `level` are written.
pub fn enabled(level: Level) -> bool {
    logger().level >= level
}

/// Write `text` on standard error when `level` is enabled, above the bars when there are.
pub fn line(level: Level, text: &str) {
    let l = logger();
    if l.level < level {
        return;
    }
    match &l.bars {
        Some(m) => m.suspend(|| eprintln!("{text}")),
        None => eprintln!("{text}"),
    }
}

/// An error: always written.
macro_rules! error {
    ($($t:tt)*) => { $crate::log::line($crate::log::Level::Error, &format!("error: {}", format_args!($($t)*))) };
}
/// A warning: written unless `--quiet` or `--log-level error`.
macro_rules! warning {
    ($($t:tt)*) => { $crate::log::line($crate::log::Level::Warn, &format!($($t)*)) };
}
/// A summary line (an output written, the closing line): shown with the warnings.
macro_rules! summary {
    ($($t:tt)*) => { $crate::log::line($crate::log::Level::Warn, &format!($($t)*)) };
}
/// Detail shown with `--log-level info`.
macro_rules! info {
    ($($t:tt)*) => { $crate::log::line($crate::log::Level::Info, &format!($($t)*)) };
}
#[allow(unused_imports)]
pub(crate) use {error, info, summary, warning};

/// The progress of the library on standard error: bars on a terminal, lines at `info`
/// (stages, files) and `debug` (POIs by tenths) otherwise, nothing with `--quiet`.
pub struct Reporter {
    bars: Option<MultiProgress>,
    state: Mutex<HashMap<Stage, StageState>>,
}

struct StageState {
    bar: Option<ProgressBar>,
    items: u64,
    done: AtomicU64,
    bytes: u64,
    t: Instant,
}

/// The progress reporter for the current flags.
pub fn reporter() -> Reporter {
    Reporter {
        bars: logger().bars.clone(),
        state: Mutex::new(HashMap::new()),
    }
}

fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar())
}

fn mb(bytes: u64) -> f64 {
    bytes as f64 / 1e6
}

impl Reporter {
    fn bar(&self, stage: Stage, items: u64, bytes: u64) -> Option<ProgressBar> {
        let m = self.bars.as_ref()?;
        let bar = if bytes > 0 {
            ProgressBar::new(bytes).with_style(style(
                "{spinner} {prefix:<26} [{bar:30}] {bytes}/{total_bytes} {msg} ({bytes_per_sec}, ETA {eta})",
            ))
        } else if items > 1 {
            ProgressBar::new(items).with_style(style(
                "{spinner} {prefix:<26} [{bar:30}] {pos}/{len} {msg} (ETA {eta})",
            ))
        } else {
            ProgressBar::new_spinner().with_style(style("{spinner} {prefix:<26} {elapsed}"))
        };
        let bar = m.add(bar);
        bar.set_prefix(stage.doing());
        if bytes > 0 {
            bar.set_message(format!("0/{items} {}s", stage.item()));
        } else if items > 1 {
            bar.set_message(format!("{}s", stage.item()));
        }
        bar.enable_steady_tick(Duration::from_millis(100));
        Some(bar)
    }
}

impl Progress for Reporter {
    fn is_cancelled(&self) -> bool {
        interrupted().load(Ordering::Relaxed)
    }

    fn start(&self, stage: Stage, items: u64, bytes: u64) {
        let bar = self.bar(stage, items, bytes);
        if bar.is_none() && items <= 1 && bytes == 0 {
            info!("{}", stage.doing());
        } else if bar.is_none() {
            let size = if bytes > 0 {
                format!(", {:.1} MB", mb(bytes))
            } else {
                String::new()
            };
            info!("{}: {items} {}(s){size}", stage.doing(), stage.item());
        }
        if let Ok(mut s) = self.state.lock() {
            s.insert(
                stage,
                StageState {
                    bar,
                    items,
                    done: AtomicU64::new(0),
                    bytes,
                    t: Instant::now(),
                },
            );
        }
    }

    fn advance(&self, stage: Stage, items: u64, bytes: u64, name: Option<&str>) {
        let Ok(s) = self.state.lock() else { return };
        let Some(st) = s.get(&stage) else { return };
        let done = st.done.fetch_add(items, Ordering::Relaxed) + items;
        match &st.bar {
            Some(bar) => {
                if st.bytes > 0 {
                    bar.inc(bytes);
                    bar.set_message(format!("{done}/{} {}s", st.items, stage.item()));
                } else {
                    bar.inc(items);
                }
            }
            None => {
                if let Some(n) = name {
                    info!("{} {done}/{}: {n}", stage.doing(), st.items);
                } else if enabled(Level::Debug) && st.items >= 10 {
                    let tenth = st.items.div_ceil(10);
                    if done % tenth == 0 || done == st.items {
                        line(
                            Level::Debug,
                            &format!("{}: {done}/{} {}s", stage.doing(), st.items, stage.item()),
                        );
                    }
                }
            }
        }
    }

    fn finish(&self, stage: Stage) {
        let Ok(mut s) = self.state.lock() else { return };
        let Some(st) = s.remove(&stage) else { return };
        let secs = st.t.elapsed().as_secs_f64();
        match st.bar {
            Some(bar) => bar.finish_and_clear(),
            None if st.items <= 1 => info!("{}: done in {secs:.2} s", stage.doing()),
            None => info!(
                "{}: done, {} {}(s) in {secs:.2} s",
                stage.doing(),
                st.done.load(Ordering::Relaxed),
                stage.item()
            ),
        }
    }
}

/// Whether `--quiet` was given.
#[allow(dead_code)]
pub fn quiet() -> bool {
    logger().quiet
}
