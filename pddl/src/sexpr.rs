//! The lexer and the s-expression reader: PDDL text to a tree of lists and atoms, each with
//! its byte span so that every later error can name file:line:column. Symbols are lowercased
//! (PDDL is case-insensitive); `;` starts a comment to the end of the line.
use crate::PddlError;
use std::ops::Range;

pub type Span = Range<usize>;

/// A node of the tree.
#[derive(Clone, Debug)]
pub enum Sx {
    List(Vec<Sx>, Span),
    /// A symbol, variable (`?x`), number or keyword (`:requirements`), lowercased.
    Atom(String, Span),
}

impl Sx {
    pub fn span(&self) -> Span {
        match self {
            Sx::List(_, s) | Sx::Atom(_, s) => s.clone(),
        }
    }
    pub fn atom(&self) -> Option<&str> {
        match self {
            Sx::Atom(a, _) => Some(a),
            Sx::List(..) => None,
        }
    }
    pub fn list(&self) -> Option<&[Sx]> {
        match self {
            Sx::List(items, _) => Some(items),
            Sx::Atom(..) => None,
        }
    }
    /// The head symbol of a list (`and` in `(and ...)`).
    pub fn head(&self) -> Option<&str> {
        self.list().and_then(|l| l.first()).and_then(Sx::atom)
    }
}

/// Read the single top-level expression of a file.
pub fn read(file: &str, text: &str) -> Result<Sx, PddlError> {
    let bytes = text.as_bytes();
    let mut stack: Vec<(Vec<Sx>, usize)> = Vec::new();
    let mut top: Option<Sx> = None;
    let mut i = 0;
    let err = |at: Range<usize>, m: &str| PddlError::at(file, text, at, m.to_string());
    while i < bytes.len() {
        let c = bytes[i];
        match c {
            b';' => {
                while i < bytes.len() && bytes[i] != b'\n' {
                    i += 1;
                }
            }
            b'(' => {
                stack.push((Vec::new(), i));
                i += 1;
            }
            b')' => {
                let Some((items, start)) = stack.pop() else {
                    return Err(err(i..i + 1, "unbalanced `)`: no list is open here"));
                };
                let node = Sx::List(items, start..i + 1);
                i += 1;
                match stack.last_mut() {
                    Some((parent, _)) => parent.push(node),
                    None => {
                        if top.is_some() {
                            return Err(err(start..i, "more than one top-level expression"));
                        }
                        top = Some(node);
                    }
                }
            }
            c if c.is_ascii_whitespace() => i += 1,
            _ => {
                let start = i;
                while i < bytes.len()
                    && !bytes[i].is_ascii_whitespace()
                    && !matches!(bytes[i], b'(' | b')' | b';')
                {
                    i += 1;
                }
                let word = text[start..i].to_ascii_lowercase();
                match stack.last_mut() {
                    Some((parent, _)) => parent.push(Sx::Atom(word, start..i)),
                    None => return Err(err(start..i, "text outside the top-level `(define ...)`")),
                }
            }
        }
    }
    if let Some((_, start)) = stack.last() {
        return Err(err(*start..*start + 1, "this `(` is never closed"));
    }
    top.ok_or_else(|| err(0..0, "the file is empty: expected `(define ...)`"))
}
