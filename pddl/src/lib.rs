//! The host's PDDL front end for the temporal planner (crate `temporal`): it reads a domain
//! and a problem in the temporal subset of seed 001 section 2.1, refuses anything outside it at
//! file:line:column naming the feature, grounds the task by reachability, evaluates external
//! functions ([`modules`]), and writes the planner's compact binary task ([`compile`]).
//!
//! Pipeline: [`sexpr`] (lexer and s-expressions with spans) -> [`ast`] (the subset as data) ->
//! [`ground`] (reachability grounding, static compilation, timed-literal windows, the binary).
pub mod ast;
pub mod ground;
pub mod modules;
pub mod sexpr;

use std::fmt;
use std::ops::Range;

pub use modules::{ExternalModule, ModuleRegistry, PathEstimate};

/// An error located in one of the two files: `file:line:column: message`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PddlError {
    pub file: String,
    pub span: Range<usize>,
    pub line: usize,
    pub column: usize,
    pub message: String,
}

impl PddlError {
    pub fn at(file: &str, text: &str, span: Range<usize>, message: String) -> Self {
        let (line, column) = line_col(text, span.start);
        Self {
            file: file.to_string(),
            span,
            line,
            column,
            message,
        }
    }
}

impl fmt::Display for PddlError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}",
            self.file, self.line, self.column, self.message
        )
    }
}

impl std::error::Error for PddlError {}

/// 1-based line and column (in characters) of a byte offset.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, before[start..].chars().count() + 1)
}

/// How times become ticks, and what the compiled task keeps.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Ticks per PDDL time unit (1000: a tick is a millisecond of a second-based domain).
    pub ticks_per_unit: u32,
    /// The separation between interfering happenings, in ticks (10 = 0.01 units, as VAL's).
    pub epsilon_ticks: u32,
    /// Leave out the ground actions that cannot help reach the goal (backward relevance,
    /// `ground::relevant_actions`): no plan is lost, and the planner's work per state shrinks
    /// with the task. Off where goals are added after compiling (the rover mission's
    /// opportunistic goals are facts of the task that the problem's goal does not name).
    pub prune_irrelevant: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            ticks_per_unit: 1000,
            epsilon_ticks: 10,
            prune_irrelevant: true,
        }
    }
}

/// A compiled task and the names the planner's ids stand for.
#[derive(Clone, Debug)]
pub struct Compiled {
    /// The binary task ([`temporal::Task::parse`] reads it).
    pub task: Vec<u8>,
    pub action_names: Vec<String>,
    pub fact_names: Vec<String>,
    pub numeric_names: Vec<String>,
    /// Facts whose timed initial literals became global windows.
    pub til_windows: usize,
    pub ticks_per_unit: u32,
    pub epsilon_ticks: u32,
}

/// A file's name and text.
#[derive(Clone, Copy, Debug)]
pub struct Source<'a> {
    pub name: &'a str,
    pub text: &'a str,
}

/// Parse, ground and translate `domain` + `problem`.
pub fn compile(
    domain: Source<'_>,
    problem: Source<'_>,
    modules: &ModuleRegistry,
    options: &Options,
) -> Result<Compiled, PddlError> {
    let files = ground::Files {
        domain: ast::Ctx {
            file: domain.name,
            text: domain.text,
        },
        problem: ast::Ctx {
            file: problem.name,
            text: problem.text,
        },
    };
    let d = ast::domain(&files.domain, &sexpr::read(domain.name, domain.text)?)?;
    let p = ast::problem(&files.problem, &sexpr::read(problem.name, problem.text)?)?;
    ground::compile(&files, &d, &p, modules, options)
}
