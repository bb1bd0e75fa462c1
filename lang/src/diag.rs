//! Diagnostics: what the front end reports (errors, warnings, notes), each with a primary
//! span and label, secondary labels, notes and the include chain of the file it is in, and
//! their rendering as plain text (no colour) through codespan-reporting: `file:line:column`,
//! the source line and a caret, as naga's WGSL front end shows its errors.

use crate::source::{SourceMap, Span};
use codespan_reporting::diagnostic as cs;
use codespan_reporting::term;

/// How serious a diagnostic is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Severity {
    /// The input is rejected.
    Error,
    /// The input is accepted; something was ignored or is suspicious.
    Warning,
    /// Information only.
    Note,
}

/// A span with the text shown under it.
#[derive(Clone, Debug, PartialEq)]
pub struct Label {
    /// Where.
    pub span: Span,
    /// What is said there (may be empty).
    pub message: String,
}

/// One message of the front end.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// Error, warning or note.
    pub severity: Severity,
    /// The headline, e.g. `expected ';' after the expression, found 'float'`.
    pub message: String,
    /// The place it is about (absent for errors with no place, such as an unreadable main
    /// file).
    pub primary: Option<Label>,
    /// Other places that explain it (the opening parenthesis of an unclosed list…).
    pub secondary: Vec<Label>,
    /// Trailing notes, e.g. `expected one of: ';', ','`.
    pub notes: Vec<String>,
    /// The `#include` directives that led to the primary span's file, innermost first.
    pub include_chain: Vec<Span>,
}

impl Diagnostic {
    /// An error at `span` labelled `label`.
    pub fn error(message: impl Into<String>, span: Span, label: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Severity::Error, message, Some(span), label)
    }

    /// A warning at `span` labelled `label`.
    pub fn warning(message: impl Into<String>, span: Span, label: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Severity::Warning, message, Some(span), label)
    }

    /// An error with no place in the source.
    pub fn error_nowhere(message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Severity::Error, message, None, "")
    }

    fn new(
        severity: Severity,
        message: impl Into<String>,
        span: Option<Span>,
        label: impl Into<String>,
    ) -> Diagnostic {
        let label = label.into();
        Diagnostic {
            severity,
            message: message.into(),
            primary: span.map(|span| Label {
                span,
                message: label,
            }),
            secondary: Vec::new(),
            notes: Vec::new(),
            include_chain: Vec::new(),
        }
    }

    /// Adds a secondary label.
    pub fn with_secondary(mut self, span: Span, message: impl Into<String>) -> Diagnostic {
        self.secondary.push(Label {
            span,
            message: message.into(),
        });
        self
    }

    /// Adds a note.
    pub fn with_note(mut self, note: impl Into<String>) -> Diagnostic {
        self.notes.push(note.into());
        self
    }

    /// Whether this is an error.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// The diagnostic as plain text: `error: message`, `--> file:line:column`, the source
    /// line with a caret under the primary span, the labels, then the notes and the include
    /// chain (`included from file:line:column`).
    pub fn render(&self, sources: &SourceMap) -> String {
        let severity = match self.severity {
            Severity::Error => cs::Severity::Error,
            Severity::Warning => cs::Severity::Warning,
            Severity::Note => cs::Severity::Note,
        };
        let mut labels = Vec::new();
        if let Some(p) = &self.primary {
            labels.push(cs::Label::primary(p.span.file, p.span.range()).with_message(&p.message));
        }
        for s in &self.secondary {
            labels.push(cs::Label::secondary(s.span.file, s.span.range()).with_message(&s.message));
        }
        let mut notes = self.notes.clone();
        for at in &self.include_chain {
            notes.push(format!("included from {}", sources.describe(*at)));
        }
        let d = cs::Diagnostic::new(severity)
            .with_message(&self.message)
            .with_labels(labels)
            .with_notes(notes);
        let config = term::Config {
            chars: term::Chars::ascii(),
            ..term::Config::default()
        };
        match term::emit_into_string(&config, sources, &d) {
            Ok(s) => s,
            // Only a span outside its file gets here (a bug): still say what went wrong.
            Err(_) => format!("{:?}: {}\n", self.severity, self.message),
        }
    }
}

/// A list of diagnostics, in the order they were found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Diagnostics(pub Vec<Diagnostic>);

impl Diagnostics {
    /// An empty list.
    pub fn new() -> Diagnostics {
        Diagnostics(Vec::new())
    }

    /// Appends one.
    pub fn push(&mut self, d: Diagnostic) {
        self.0.push(d);
    }

    /// Whether any is an error.
    pub fn has_errors(&self) -> bool {
        self.0.iter().any(Diagnostic::is_error)
    }

    /// Number of diagnostics.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The diagnostics in order.
    pub fn iter(&self) -> std::slice::Iter<'_, Diagnostic> {
        self.0.iter()
    }

    /// Every diagnostic rendered, one after the other.
    pub fn render(&self, sources: &SourceMap) -> String {
        self.0.iter().map(|d| d.render(sources)).collect()
    }
}

impl From<Box<Diagnostic>> for Diagnostics {
    fn from(d: Box<Diagnostic>) -> Diagnostics {
        Diagnostics(vec![*d])
    }
}

impl From<Diagnostic> for Diagnostics {
    fn from(d: Diagnostic) -> Diagnostics {
        Diagnostics(vec![d])
    }
}
