//! One located-error type for every file `hil` reads (scenarios, task networks, budgets): the
//! file, the line and column, the field path (`events[2].warm_reset.recovery`), the message, and
//! the target's validation code when the target's validator refused it.
//!
//! [`Diagnostic`]'s `Display` is one line, `file:line:column: field: message`, the form editors
//! and CI logs understand; [`Diagnostic::render`] adds the offending source lines underneath
//! (rendered by `codespan-reporting`) for people at a terminal.
use std::fmt;
use std::ops::Range;
use std::path::Path;
use std::sync::Arc;

use codespan_reporting::diagnostic::{Diagnostic as Report, Label};
use codespan_reporting::files::SimpleFile;
use codespan_reporting::term::{self, Config, DisplayStyle};

/// A file's name (as the user gave it) and text, shared by every diagnostic that points into it.
#[derive(Clone, Debug)]
pub struct SourceFile {
    pub name: String,
    pub text: Arc<str>,
}

impl SourceFile {
    /// Read `path`; an unreadable file is a diagnostic that names it.
    pub fn read(path: &Path) -> Result<Self, Diagnostic> {
        match std::fs::read_to_string(path) {
            Ok(text) => Ok(Self::new(path.display().to_string(), text)),
            Err(e) => Err(Diagnostic::unreadable(path, &e)),
        }
    }

    pub fn new(name: impl Into<String>, text: impl Into<Arc<str>>) -> Self {
        Self {
            name: name.into(),
            text: text.into(),
        }
    }

    /// A diagnostic at `span` of this file.
    pub fn error(
        &self,
        span: Range<usize>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Diagnostic {
        Diagnostic {
            file: self.name.clone(),
            text: Some(self.text.clone()),
            span: Some(span),
            field: field.into(),
            message: message.into(),
            code: None,
        }
    }

    /// The byte range of the TOML field at `path` (`events[2].warm_reset.recovery`,
    /// `spacecraft.gnc`): its value, or the deepest enclosing part of the path the file has (a
    /// defaulted field points at its table). The whole file's start if nothing matches.
    pub fn locate(&self, path: &str) -> Range<usize> {
        let Ok(doc) = toml_edit::ImDocument::parse(&*self.text) else {
            return 0..0;
        };
        let mut item = doc.as_item();
        let mut span = 0..0;
        for segment in path_segments(path) {
            let next = match segment {
                Segment::Key(k) => item.get(k),
                Segment::Index(i) => item.get(i),
            };
            let Some(next) = next else { break };
            if let Some(s) = next.span() {
                span = s;
            }
            item = next;
        }
        span
    }

    /// A diagnostic at the TOML field `path` (located with [`Self::locate`]).
    pub fn error_at(&self, path: &str, message: impl Into<String>) -> Diagnostic {
        self.error(self.locate(path), path, message)
    }

    /// A TOML parse or type error of this file: toml reports the span, the message names the
    /// field or the expected type; `field` is the path of the table being read.
    pub fn toml_error(&self, e: &toml::de::Error, field: &str) -> Diagnostic {
        let span = e.span().unwrap_or(0..0);
        let message = e.message().trim().to_string();
        let field = if field.is_empty() {
            table_path_at(&self.text, span.start)
        } else {
            field.to_string()
        };
        self.error(span, field, message)
    }
}

/// An error located in a file.
#[derive(Clone, Debug)]
pub struct Diagnostic {
    pub file: String,
    text: Option<Arc<str>>,
    /// Byte range in the file; None when there is no position (the file is unreadable).
    span: Option<Range<usize>>,
    /// The field concerned, as a path (`task[2].constraints[0]`, `mission.end`).
    pub field: String,
    pub message: String,
    /// The target's validation code, when its validator refused the value.
    pub code: Option<u16>,
}

impl Diagnostic {
    /// `path` could not be read.
    pub fn unreadable(path: &Path, e: &std::io::Error) -> Self {
        Self {
            file: path.display().to_string(),
            text: None,
            span: None,
            field: String::new(),
            message: format!("cannot read the file: {e}"),
            code: None,
        }
    }

    /// With the target's validation code.
    pub fn with_code(mut self, code: u16) -> Self {
        self.code = Some(code);
        self
    }

    /// 1-based line and column, when the diagnostic has a position.
    pub fn line_col(&self) -> Option<(usize, usize)> {
        let (text, span) = (self.text.as_deref()?, self.span.as_ref()?);
        Some(line_col(text, span.start))
    }

    pub fn line(&self) -> usize {
        self.line_col().map_or(0, |(l, _)| l)
    }

    pub fn column(&self) -> usize {
        self.line_col().map_or(0, |(_, c)| c)
    }

    /// The one-line form followed by the source lines it points at.
    pub fn render(&self) -> String {
        let (Some(text), Some(span)) = (self.text.as_deref(), self.span.clone()) else {
            return self.to_string();
        };
        let file = SimpleFile::new(self.file.as_str(), text);
        let end = span.end.max(span.start).min(text.len());
        let start = span.start.min(end);
        let label = Label::primary((), start..end).with_message(self.message.as_str());
        let mut report = Report::error().with_labels(vec![label]);
        if let Some(code) = self.code {
            report = report.with_code(format!("validation code {code}"));
        }
        let config = Config {
            display_style: DisplayStyle::Rich,
            ..Config::default()
        };
        let snippet = term::emit_into_string(&config, &file, &report).unwrap_or_default();
        // codespan's header line repeats our one-line form less well: keep its source lines.
        let body: Vec<&str> = snippet.lines().skip(1).collect();
        format!("{self}\n{}", body.join("\n"))
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some((line, column)) = self.line_col() {
            write!(f, ":{line}:{column}")?;
        }
        if !self.field.is_empty() {
            write!(f, ": {}", self.field)?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for Diagnostic {}

enum Segment<'a> {
    Key(&'a str),
    Index(usize),
}

/// `a.b[2].c` as `a`, `b`, `2`, `c`.
fn path_segments(path: &str) -> Vec<Segment<'_>> {
    let mut out = Vec::new();
    for part in path.split('.').filter(|p| !p.is_empty()) {
        let (key, rest) = part.split_at(part.find('[').unwrap_or(part.len()));
        if !key.is_empty() {
            out.push(Segment::Key(key));
        }
        for index in rest.split('[').filter_map(|i| i.strip_suffix(']')) {
            match index.parse() {
                Ok(i) => out.push(Segment::Index(i)),
                Err(_) => return out,
            }
        }
    }
    out
}

/// 1-based line and column of a byte offset in `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    (line, column)
}

/// The TOML table (header path) that the byte `offset` of `text` is in: `mission`,
/// `events[2]`, `spacecraft.gnc`; empty before the first header. Used to name the field of a
/// parse error toml reports only by position.
pub fn table_path_at(text: &str, offset: usize) -> String {
    let mut counts: std::collections::BTreeMap<String, usize> = Default::default();
    let mut current = String::new();
    let mut pos = 0;
    for line in text.split_inclusive('\n') {
        if pos > offset {
            break;
        }
        let t = line.trim();
        if let Some(name) = t.strip_prefix("[[").and_then(|r| r.split("]]").next()) {
            let name = name.trim().to_string();
            let n = counts.entry(name.clone()).or_insert(0);
            current = format!("{name}[{n}]");
            *n += 1;
        } else if let Some(name) = t.strip_prefix('[').and_then(|r| r.split(']').next()) {
            current = name.trim().to_string();
        }
        pos += line.len();
    }
    current
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_is_file_line_column_field_message() {
        let f = SourceFile::new("s.toml", "name = \"x\"\n[mission]\nend = \"25:00\"\n");
        let d = f.error(27..34, "mission.end", "hour 25 out of range");
        assert_eq!(
            d.to_string(),
            "s.toml:3:7: mission.end: hour 25 out of range"
        );
        let r = d.render();
        assert!(r.starts_with("s.toml:3:7: mission.end: hour 25"), "{r}");
        assert!(r.contains("end = \"25:00\""), "{r}");
        assert!(r.contains("^^^^^^^"), "{r}");
    }

    #[test]
    fn an_unreadable_file_has_no_position_but_says_why() {
        let e = SourceFile::read(Path::new("/nonexistent/x.toml")).unwrap_err();
        let s = e.to_string();
        assert!(
            s.starts_with("/nonexistent/x.toml: cannot read the file: "),
            "{s}"
        );
        assert!(!s.contains(":0:0"), "{s}");
    }

    #[test]
    fn fields_are_located_by_path() {
        let text = "name = \"x\"\n[[events]]\nat = \"10:00\"\n[[events]]\nat = \"11:00\"\nwarm_reset = { recovery = \"3 fortnights\" }\n[spacecraft.gnc]\nslew = \"15min\"\n";
        let f = SourceFile::new("s.toml", text);
        let at = |p: &str| {
            let d = f.error_at(p, "m");
            (d.line(), d.column())
        };
        assert_eq!(at("events[1].warm_reset.recovery"), (6, 27));
        assert_eq!(at("events[1].at"), (5, 6));
        assert_eq!(at("spacecraft.gnc.slew"), (8, 8));
        // A field the file does not have points at the deepest part it has.
        assert_eq!(at("spacecraft.gnc.initial"), (7, 1));
        assert_eq!(f.error_at("events[1].at", "m").field, "events[1].at");
    }

    #[test]
    fn table_paths_count_array_tables() {
        let text = "name = 1\n[[events]]\nat = 1\n[[events]]\nat = 2\n[spacecraft.gnc]\nx = 1\n";
        assert_eq!(table_path_at(text, 0), "");
        assert_eq!(
            table_path_at(text, text.find("at = 2").unwrap()),
            "events[1]"
        );
        assert_eq!(
            table_path_at(text, text.find("x = 1").unwrap()),
            "spacecraft.gnc"
        );
    }

    #[test]
    fn line_col_counts_characters_from_one() {
        assert_eq!(line_col("ab\ncd", 0), (1, 1));
        assert_eq!(line_col("ab\ncd", 4), (2, 2));
        assert_eq!(line_col("é\nx", 3), (2, 1));
    }
}
