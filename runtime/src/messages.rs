//! Messages shaders write: OSL's `printf`, `warning` and `error` ([`Op::Print`]).
//!
//! Every CPU back end writes a fragment's messages, formatted, to the **calling thread's
//! log**, in the order it shades: the fragments of one call in order, the lanes of a packet
//! in lane order (lanes that are masked off or pad a packet write nothing), a fragment's
//! messages in program order. Whoever shades takes the log with [`take`] after shading a
//! range of fragments and puts the ranges in fragment order (the `shade` command does it per
//! row, so its output is the same for any number of threads). Nothing goes to stdout from
//! here: what is printed where is the caller's choice.
//!
//! A thread's log holds at most [`LOG_LIMIT`] bytes of text; messages past it are counted
//! in [`Messages::dropped`], not kept, so a shader printing in a long loop on every fragment
//! cannot exhaust memory. It owns the log and the formatting of a message's values; it must
//! not know which back end shades.
//!
//! [`Op::Print`]: shadenet_graph::ir::Op::Print

use shadenet_graph::ir::Severity;
use shadenet_graph::ops::printf::{self, Arg};
use std::cell::{Cell, RefCell};

/// The most bytes of message text one thread's log holds before it drops messages.
pub const LOG_LIMIT: usize = 16 << 20;

/// One message a fragment wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Message {
    /// `printf`, `warning` or `error`.
    pub severity: Severity,
    /// The formatted text, as the shader wrote it (a `printf` ends its own lines).
    pub text: String,
}

/// The messages a thread's shading wrote since the last [`take`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Messages {
    /// The messages, in the order they were written.
    pub list: Vec<Message>,
    /// Messages left out because the log was full ([`LOG_LIMIT`]).
    pub dropped: u64,
}

impl Messages {
    /// Appends another range's messages after these.
    pub fn append(&mut self, mut other: Messages) {
        self.list.append(&mut other.list);
        self.dropped += other.dropped;
    }

    /// Whether there is nothing: no message and none dropped.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty() && self.dropped == 0
    }

    /// How many messages are errors.
    pub fn errors(&self) -> usize {
        self.count(Severity::Error)
    }

    /// How many messages are of `severity`.
    pub fn count(&self, severity: Severity) -> usize {
        self.list.iter().filter(|m| m.severity == severity).count()
    }
}

#[derive(Default)]
struct Log {
    messages: Messages,
    bytes: usize,
    /// Messages of a batch call not yet in fragment order ([`write_at`]), with their
    /// fragment's index in the batch.
    pending: Vec<(u32, Message)>,
}

impl Log {
    /// Whether `text` still fits; counts a drop where it does not.
    fn fits(&mut self, text: &str) -> bool {
        if self.bytes + text.len() > LOG_LIMIT {
            self.messages.dropped += 1;
            return false;
        }
        self.bytes += text.len();
        true
    }
}

thread_local! {
    static LOG: RefCell<Log> = RefCell::new(Log::default());
    static MUTED: Cell<bool> = const { Cell::new(false) };
}

/// Writes one message: `format` with `args` ([`printf::format`]). A format that does not fit
/// its arguments (a program the validator would reject) writes the reason as an error
/// instead. Does nothing while the thread is [`muted`].
pub fn write(severity: Severity, format: &str, args: &[Arg]) {
    record(None, severity, format, args);
}

/// [`write`] for fragment `fragment` of a batch that runs its fragments in lockstep (a
/// packet's lanes write one op's messages together): the message waits until
/// [`flush_batch`] puts the batch's messages in fragment order.
pub fn write_at(fragment: u32, severity: Severity, format: &str, args: &[Arg]) {
    record(Some(fragment), severity, format, args);
}

/// The message into the log (`at: None`) or among the batch's pending ones.
fn record(at: Option<u32>, severity: Severity, format: &str, args: &[Arg]) {
    if MUTED.get() {
        return;
    }
    let m = message(severity, format, args);
    LOG.with_borrow_mut(|log| {
        if log.fits(&m.text) {
            match at {
                Some(f) => log.pending.push((f, m)),
                None => log.messages.list.push(m),
            }
        }
    });
}

/// Moves the messages [`write_at`] holds into the log, in fragment order (each fragment's
/// own in the order it wrote them): what the thread's log would hold had the batch shaded
/// one fragment after another.
pub fn flush_batch() {
    LOG.with_borrow_mut(|log| {
        if log.pending.is_empty() {
            return;
        }
        let mut pending = std::mem::take(&mut log.pending);
        pending.sort_by_key(|(f, _)| *f);
        log.messages
            .list
            .extend(pending.into_iter().map(|(_, m)| m));
    });
}

/// The message `format` with `args` writes: the reason as an error where they do not fit.
fn message(severity: Severity, format: &str, args: &[Arg]) -> Message {
    match printf::format(format, args) {
        Ok(text) => Message { severity, text },
        Err(e) => Message {
            severity: Severity::Error,
            text: format!("message format {format:?}: {e}"),
        },
    }
}

/// Takes the calling thread's messages, leaving its log empty (messages of a batch not yet
/// flushed stay).
pub fn take() -> Messages {
    LOG.with_borrow_mut(|log| {
        log.bytes = log.pending.iter().map(|(_, m)| m.text.len()).sum();
        std::mem::take(&mut log.messages)
    })
}

/// Runs `f` with the calling thread's messages silenced (what shades a packet's padding
/// lanes, whose fragments are not the caller's).
pub fn muted<R>(f: impl FnOnce() -> R) -> R {
    let outer = MUTED.replace(true);
    let r = f();
    MUTED.set(outer);
    r
}

/// A float as a message shows it: the f32 the shader holds (the f64 reference rounds).
pub fn float_arg(x: f64) -> Arg {
    Arg::Float(f64::from(x as f32))
}

/// Components of an aggregate as a message shows them (each rounded to f32).
pub fn floats_arg(xs: impl IntoIterator<Item = f64>) -> Arg {
    Arg::Floats(xs.into_iter().map(|x| f64::from(x as f32)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thread_keeps_its_messages_in_order_until_taken() {
        take();
        write(Severity::Printf, "a %d\n", &[Arg::Int(1)]);
        muted(|| write(Severity::Printf, "padding\n", &[]));
        write(Severity::Warning, "b %g", &[float_arg(0.1)]);
        let other = std::thread::spawn(|| {
            write(Severity::Error, "elsewhere", &[]);
            take()
        })
        .join()
        .unwrap();
        let m = take();
        assert_eq!(
            m.list,
            vec![
                Message {
                    severity: Severity::Printf,
                    text: "a 1\n".into()
                },
                Message {
                    severity: Severity::Warning,
                    text: "b 0.1".into()
                },
            ]
        );
        assert_eq!(other.errors(), 1);
        assert!(take().is_empty());
    }

    #[test]
    fn a_batch_is_put_in_fragment_order() {
        take();
        write(Severity::Printf, "before\n", &[]);
        for op in ["a", "b"] {
            for lane in [2u32, 0, 1] {
                write_at(
                    lane,
                    Severity::Printf,
                    "%s%d ",
                    &[Arg::Str(op.into()), Arg::Int(lane.into())],
                );
            }
        }
        assert_eq!(take().list.len(), 1, "a batch waits for its flush");
        flush_batch();
        let text: String = take().list.into_iter().map(|m| m.text).collect();
        assert_eq!(text, "a0 b0 a1 b1 a2 b2 ");
    }

    #[test]
    fn a_full_log_counts_what_it_drops() {
        take();
        let line = "x".repeat(1 << 20);
        for _ in 0..20 {
            write(Severity::Printf, "%s", &[Arg::Str(line.clone())]);
        }
        let m = take();
        assert_eq!(m.list.len(), LOG_LIMIT >> 20);
        assert_eq!(m.dropped, 20 - (LOG_LIMIT >> 20) as u64);
        // Taking empties the log: it fills again.
        write(Severity::Printf, "%s", &[Arg::Str(line)]);
        assert_eq!(take().list.len(), 1);
    }

    #[test]
    fn a_bad_format_is_an_error_message() {
        take();
        write(Severity::Printf, "%d", &[Arg::Float(1.0)]);
        let m = take();
        assert_eq!(m.errors(), 1);
        assert!(m.list[0].text.contains("takes an int"), "{:?}", m.list);
    }
}
