//! The PDDL subset of seed 001 section 2.1 as data: durative actions with at-start, over-all and
//! at-end conditions and effects, [lb, ub] durations, timed initial literals, numeric conditions
//! and discrete numeric effects, typing, equality, and external-function modules (section 4.5).
//! Everything outside the subset is refused where it appears, naming the feature.
use crate::sexpr::{Span, Sx};
use crate::PddlError;

/// Requirements accepted (others are refused by name).
const SUPPORTED_REQUIREMENTS: &[&str] = &[
    ":strips",
    ":typing",
    ":equality",
    ":durative-actions",
    ":duration-inequalities",
    ":timed-initial-literals",
    ":fluents",
    ":numeric-fluents",
    ":negative-preconditions",
];

#[derive(Clone, Debug)]
pub struct Param {
    pub name: String,
    pub ty: String,
}

#[derive(Clone, Debug)]
pub struct Signature {
    pub name: String,
    pub params: Vec<Param>,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Term {
    Var(String),
    Const(String),
}

#[derive(Clone, Debug)]
pub struct Atom {
    pub pred: String,
    pub args: Vec<Term>,
    pub span: Span,
}

#[derive(Clone, Debug)]
pub enum Expr {
    Number(f64),
    Duration,
    Function(String, Vec<Term>, Span),
    Binary(char, Box<Expr>, Box<Expr>),
    Negate(Box<Expr>),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cmp {
    Ge,
    Le,
    Eq,
    Gt,
    Lt,
}

#[derive(Clone, Debug)]
pub enum Condition {
    Atom {
        atom: Atom,
        positive: bool,
    },
    Equal {
        a: Term,
        b: Term,
        positive: bool,
    },
    Numeric {
        cmp: Cmp,
        lhs: Expr,
        rhs: Expr,
        span: Span,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum When {
    Start,
    OverAll,
    End,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NumOp {
    Assign,
    Increase,
    Decrease,
}

#[derive(Clone, Debug)]
pub enum Effect {
    Add(Atom),
    Del(Atom),
    Numeric {
        op: NumOp,
        function: String,
        args: Vec<Term>,
        value: Expr,
        span: Span,
    },
}

#[derive(Clone, Debug)]
pub struct DurativeAction {
    pub name: String,
    pub span: Span,
    pub params: Vec<Param>,
    /// Lower and upper bounds (None: unbounded above).
    pub duration: (Expr, Option<Expr>),
    pub duration_span: Span,
    pub conditions: Vec<(When, Condition)>,
    /// Effects at start (`false`) or at end (`true`).
    pub effects: Vec<(bool, Effect)>,
}

#[derive(Clone, Debug)]
pub struct Module {
    pub name: String,
    pub span: Span,
    pub functions: Vec<Signature>,
}

#[derive(Clone, Debug, Default)]
pub struct Domain {
    pub name: String,
    /// (type, parent).
    pub types: Vec<(String, String)>,
    pub constants: Vec<(String, String)>,
    pub predicates: Vec<Signature>,
    pub functions: Vec<Signature>,
    pub modules: Vec<Module>,
    pub actions: Vec<DurativeAction>,
}

#[derive(Clone, Debug)]
pub enum InitItem {
    Atom(Atom),
    Value {
        function: String,
        args: Vec<Term>,
        value: f64,
        span: Span,
    },
    Til {
        time: f64,
        atom: Atom,
        positive: bool,
        span: Span,
    },
}

#[derive(Clone, Debug, Default)]
pub struct Problem {
    pub name: String,
    pub domain: String,
    pub objects: Vec<(String, String)>,
    pub init: Vec<InitItem>,
    pub goal: Vec<Condition>,
}

/// Where errors point: a file's name and text.
pub struct Ctx<'a> {
    pub file: &'a str,
    pub text: &'a str,
}

impl Ctx<'_> {
    pub fn err(&self, span: Span, message: impl Into<String>) -> PddlError {
        PddlError::at(self.file, self.text, span, message.into())
    }
    fn unsupported(&self, span: Span, feature: &str) -> PddlError {
        self.err(span, format!("unsupported PDDL feature: {feature}"))
    }
    fn atom<'s>(&self, sx: &'s Sx, what: &str) -> Result<&'s str, PddlError> {
        sx.atom()
            .ok_or_else(|| self.err(sx.span(), format!("expected {what}, found a list")))
    }
    fn list<'s>(&self, sx: &'s Sx, what: &str) -> Result<&'s [Sx], PddlError> {
        sx.list().ok_or_else(|| {
            self.err(
                sx.span(),
                format!("expected {what}, found `{}`", sx.atom().unwrap_or("")),
            )
        })
    }
}

/// `a b - t c - u d` as (name, type) pairs; untyped names are `object`.
fn typed_list(ctx: &Ctx<'_>, items: &[Sx]) -> Result<Vec<(String, String, Span)>, PddlError> {
    let mut out = Vec::new();
    let mut pending: Vec<(String, Span)> = Vec::new();
    let mut i = 0;
    while i < items.len() {
        let sx = &items[i];
        match sx {
            Sx::Atom(a, span) if a == "-" => {
                let Some(ty) = items.get(i + 1) else {
                    return Err(ctx.err(span.clone(), "`-` must be followed by a type"));
                };
                if ty.head() == Some("either") {
                    return Err(ctx.unsupported(ty.span(), "`either` types"));
                }
                let ty = ctx.atom(ty, "a type name")?.to_string();
                for (n, s) in pending.drain(..) {
                    out.push((n, ty.clone(), s));
                }
                i += 2;
            }
            Sx::Atom(a, span) => {
                pending.push((a.clone(), span.clone()));
                i += 1;
            }
            Sx::List(_, span) => {
                return Err(ctx.err(
                    span.clone(),
                    "expected a name in a typed list, found a list",
                ))
            }
        }
    }
    for (n, s) in pending {
        out.push((n, "object".to_string(), s));
    }
    Ok(out)
}

fn params(ctx: &Ctx<'_>, sx: &Sx) -> Result<Vec<Param>, PddlError> {
    let items = ctx.list(sx, "a parameter list")?;
    typed_list(ctx, items)?
        .into_iter()
        .map(|(name, ty, span)| {
            if !name.starts_with('?') {
                return Err(ctx.err(span, format!("parameter `{name}` must start with `?`")));
            }
            Ok(Param { name, ty })
        })
        .collect()
}

fn signature(ctx: &Ctx<'_>, sx: &Sx) -> Result<Signature, PddlError> {
    let items = ctx.list(sx, "a declaration `(name ?x - type ...)`")?;
    let Some(first) = items.first() else {
        return Err(ctx.err(sx.span(), "empty declaration"));
    };
    let name = ctx.atom(first, "a name")?.to_string();
    let ps = typed_list(ctx, &items[1..])?
        .into_iter()
        .map(|(name, ty, _)| Param { name, ty })
        .collect();
    Ok(Signature {
        name,
        params: ps,
        span: sx.span(),
    })
}

fn term(ctx: &Ctx<'_>, sx: &Sx) -> Result<Term, PddlError> {
    let a = ctx.atom(sx, "a variable or object")?;
    Ok(if a.starts_with('?') {
        Term::Var(a.to_string())
    } else {
        Term::Const(a.to_string())
    })
}

fn atom(ctx: &Ctx<'_>, sx: &Sx) -> Result<Atom, PddlError> {
    let items = ctx.list(sx, "an atom `(predicate args...)`")?;
    let Some(first) = items.first() else {
        return Err(ctx.err(sx.span(), "empty atom"));
    };
    let pred = ctx.atom(first, "a predicate name")?.to_string();
    let args = items[1..]
        .iter()
        .map(|a| term(ctx, a))
        .collect::<Result<_, _>>()?;
    Ok(Atom {
        pred,
        args,
        span: sx.span(),
    })
}

pub fn number(ctx: &Ctx<'_>, sx: &Sx) -> Result<f64, PddlError> {
    let a = ctx.atom(sx, "a number")?;
    a.parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| ctx.err(sx.span(), format!("`{a}` is not a number")))
}

fn expr(ctx: &Ctx<'_>, sx: &Sx) -> Result<Expr, PddlError> {
    match sx {
        Sx::Atom(a, span) => {
            if a == "?duration" {
                Ok(Expr::Duration)
            } else if a == "#t" {
                Err(ctx.unsupported(span.clone(), "continuous effects (`#t`)"))
            } else if let Ok(x) = a.parse::<f64>() {
                Ok(Expr::Number(x))
            } else {
                // A 0-ary function written without parentheses.
                Ok(Expr::Function(a.clone(), Vec::new(), span.clone()))
            }
        }
        Sx::List(items, span) => {
            let head = sx.head().unwrap_or("");
            match (head, items.len()) {
                ("+" | "*" | "/", 3) | ("-", 3) => Ok(Expr::Binary(
                    head.chars().next().unwrap_or('+'),
                    Box::new(expr(ctx, &items[1])?),
                    Box::new(expr(ctx, &items[2])?),
                )),
                ("-", 2) => Ok(Expr::Negate(Box::new(expr(ctx, &items[1])?))),
                ("+" | "*", n) if n > 3 => {
                    let mut acc = expr(ctx, &items[1])?;
                    for it in &items[2..] {
                        acc = Expr::Binary(
                            head.chars().next().unwrap_or('+'),
                            Box::new(acc),
                            Box::new(expr(ctx, it)?),
                        );
                    }
                    Ok(acc)
                }
                ("", _) => Err(ctx.err(span.clone(), "expected a numeric expression")),
                _ => {
                    let args = items[1..]
                        .iter()
                        .map(|a| term(ctx, a))
                        .collect::<Result<_, _>>()?;
                    Ok(Expr::Function(head.to_string(), args, span.clone()))
                }
            }
        }
    }
}

/// `(at start ...)`, `(at end ...)` or `(over all ...)`, as opposed to an atom of a predicate
/// named `at`.
fn is_time_specifier(items: &[Sx]) -> bool {
    matches!(
        (
            items.first().and_then(Sx::atom),
            items.get(1).and_then(Sx::atom)
        ),
        (Some("at"), Some("start" | "end")) | (Some("over"), Some("all"))
    )
}

fn comparison(head: &str) -> Option<Cmp> {
    Some(match head {
        ">=" => Cmp::Ge,
        "<=" => Cmp::Le,
        "=" => Cmp::Eq,
        ">" => Cmp::Gt,
        "<" => Cmp::Lt,
        _ => return None,
    })
}

/// A condition (no time specifier), flattened into `out`.
fn condition(ctx: &Ctx<'_>, sx: &Sx, out: &mut Vec<Condition>) -> Result<(), PddlError> {
    let items = ctx.list(sx, "a condition")?;
    let head = sx.head().unwrap_or("");
    match head {
        "and" => {
            for c in &items[1..] {
                condition(ctx, c, out)?;
            }
        }
        "not" => {
            let [_, inner] = items else {
                return Err(ctx.err(sx.span(), "`not` takes one condition"));
            };
            match inner.head() {
                Some("=") => {
                    let c = equality(ctx, inner, false)?;
                    out.push(c);
                }
                Some("and" | "or" | "not" | "forall" | "exists" | "imply") => {
                    return Err(ctx.unsupported(inner.span(), "negated compound conditions"))
                }
                _ => out.push(Condition::Atom {
                    atom: atom(ctx, inner)?,
                    positive: false,
                }),
            }
        }
        "or" => return Err(ctx.unsupported(sx.span(), "disjunctive conditions (`or`)")),
        "imply" => return Err(ctx.unsupported(sx.span(), "`imply` conditions")),
        "forall" => return Err(ctx.unsupported(sx.span(), "universal conditions (`forall`)")),
        "exists" => return Err(ctx.unsupported(sx.span(), "existential conditions (`exists`)")),
        "preference" => return Err(ctx.unsupported(sx.span(), "preferences")),
        "at" | "over" if is_time_specifier(items) => {
            return Err(ctx.err(
                sx.span(),
                "a time specifier (`at start`, `over all`, `at end`) is not allowed here",
            ))
        }
        h if comparison(h).is_some() => {
            // `(= ?a ?b)` between terms is equality; otherwise numeric.
            let is_terms = items.len() == 3
                && items[1..]
                    .iter()
                    .all(|x| x.atom().is_some_and(|a| a.starts_with('?')));
            if h == "=" && is_terms {
                out.push(equality(ctx, sx, true)?);
            } else {
                let [_, l, r] = items else {
                    return Err(ctx.err(sx.span(), "a comparison takes two expressions"));
                };
                out.push(Condition::Numeric {
                    cmp: comparison(h).unwrap_or(Cmp::Eq),
                    lhs: expr(ctx, l)?,
                    rhs: expr(ctx, r)?,
                    span: sx.span(),
                });
            }
        }
        _ => out.push(Condition::Atom {
            atom: atom(ctx, sx)?,
            positive: true,
        }),
    }
    Ok(())
}

fn equality(ctx: &Ctx<'_>, sx: &Sx, positive: bool) -> Result<Condition, PddlError> {
    let items = ctx.list(sx, "an equality")?;
    let [_, a, b] = items else {
        return Err(ctx.err(sx.span(), "`=` takes two terms"));
    };
    Ok(Condition::Equal {
        a: term(ctx, a)?,
        b: term(ctx, b)?,
        positive,
    })
}

/// `(at start C)` / `(over all C)` / `(at end C)` and conjunctions of them.
fn timed_conditions(
    ctx: &Ctx<'_>,
    sx: &Sx,
    out: &mut Vec<(When, Condition)>,
) -> Result<(), PddlError> {
    let items = ctx.list(sx, "a timed condition")?;
    if items.is_empty() {
        return Ok(());
    }
    match sx.head().unwrap_or("") {
        "and" => {
            for c in &items[1..] {
                timed_conditions(ctx, c, out)?;
            }
            Ok(())
        }
        "at" | "over" if is_time_specifier(items) => {
            let when = match (items.first().and_then(Sx::atom), items.get(1).and_then(Sx::atom)) {
                (Some("at"), Some("start")) => When::Start,
                (Some("at"), Some("end")) => When::End,
                (Some("over"), Some("all")) => When::OverAll,
                _ => {
                    return Err(ctx.err(
                        sx.span(),
                        "expected `at start`, `at end` or `over all` before the condition",
                    ))
                }
            };
            let Some(inner) = items.get(2) else {
                return Err(ctx.err(sx.span(), "a timed condition needs a condition"));
            };
            let mut cs = Vec::new();
            condition(ctx, inner, &mut cs)?;
            out.extend(cs.into_iter().map(|c| (when, c)));
            Ok(())
        }
        "forall" => Err(ctx.unsupported(sx.span(), "universal conditions (`forall`)")),
        "preference" => Err(ctx.unsupported(sx.span(), "preferences")),
        _ => Err(ctx.err(
            sx.span(),
            "a durative action's condition needs a time specifier (`at start`, `over all`, `at end`)",
        )),
    }
}

fn effect(ctx: &Ctx<'_>, sx: &Sx, out: &mut Vec<Effect>) -> Result<(), PddlError> {
    let items = ctx.list(sx, "an effect")?;
    match sx.head().unwrap_or("") {
        "and" => {
            for e in &items[1..] {
                effect(ctx, e, out)?;
            }
        }
        "not" => {
            let [_, inner] = items else {
                return Err(ctx.err(sx.span(), "`not` takes one atom"));
            };
            out.push(Effect::Del(atom(ctx, inner)?));
        }
        "when" => return Err(ctx.unsupported(sx.span(), "conditional effects (`when`)")),
        "forall" => return Err(ctx.unsupported(sx.span(), "universal effects (`forall`)")),
        "scale-up" | "scale-down" => {
            return Err(ctx.unsupported(sx.span(), "`scale-up`/`scale-down` effects"))
        }
        h @ ("assign" | "increase" | "decrease") => {
            let [_, f, v] = items else {
                return Err(ctx.err(sx.span(), format!("`{h}` takes a function and a value")));
            };
            if v.list()
                .is_some_and(|l| l.len() == 3 && l.iter().any(|x| x.atom() == Some("#t")))
            {
                return Err(ctx.unsupported(v.span(), "continuous effects (`#t`)"));
            }
            let fitems = ctx.list(f, "a function term `(f args...)`")?;
            let name = fitems
                .first()
                .and_then(Sx::atom)
                .ok_or_else(|| ctx.err(f.span(), "expected a function name"))?;
            out.push(Effect::Numeric {
                op: match h {
                    "assign" => NumOp::Assign,
                    "increase" => NumOp::Increase,
                    _ => NumOp::Decrease,
                },
                function: name.to_string(),
                args: fitems[1..]
                    .iter()
                    .map(|a| term(ctx, a))
                    .collect::<Result<_, _>>()?,
                value: expr(ctx, v)?,
                span: sx.span(),
            });
        }
        "at" | "over" if is_time_specifier(items) => {
            return Err(ctx.err(
                sx.span(),
                "a time specifier is not allowed inside an effect",
            ))
        }
        _ => out.push(Effect::Add(atom(ctx, sx)?)),
    }
    Ok(())
}

fn timed_effects(ctx: &Ctx<'_>, sx: &Sx, out: &mut Vec<(bool, Effect)>) -> Result<(), PddlError> {
    let items = ctx.list(sx, "a timed effect")?;
    if items.is_empty() {
        return Ok(());
    }
    match sx.head().unwrap_or("") {
        "and" => {
            for e in &items[1..] {
                timed_effects(ctx, e, out)?;
            }
            Ok(())
        }
        "at" if is_time_specifier(items) => {
            let end = match items.get(1).and_then(Sx::atom) {
                Some("start") => false,
                Some("end") => true,
                _ => return Err(ctx.err(sx.span(), "expected `at start` or `at end`")),
            };
            let Some(inner) = items.get(2) else {
                return Err(ctx.err(sx.span(), "a timed effect needs an effect"));
            };
            let mut es = Vec::new();
            effect(ctx, inner, &mut es)?;
            out.extend(es.into_iter().map(|e| (end, e)));
            Ok(())
        }
        "increase" | "decrease" => Err(ctx.unsupported(
            sx.span(),
            "continuous effects (a numeric effect without `at start`/`at end`)",
        )),
        "forall" => Err(ctx.unsupported(sx.span(), "universal effects (`forall`)")),
        "when" => Err(ctx.unsupported(sx.span(), "conditional effects (`when`)")),
        _ => Err(ctx.err(
            sx.span(),
            "a durative action's effect needs a time specifier (`at start` or `at end`)",
        )),
    }
}

fn duration(ctx: &Ctx<'_>, sx: &Sx) -> Result<(Expr, Option<Expr>), PddlError> {
    let mut lb: Option<Expr> = None;
    let mut ub: Option<Expr> = None;
    fn walk(
        ctx: &Ctx<'_>,
        sx: &Sx,
        lb: &mut Option<Expr>,
        ub: &mut Option<Expr>,
    ) -> Result<(), PddlError> {
        let items = ctx.list(sx, "a duration constraint")?;
        let head = sx.head().unwrap_or("");
        if head == "and" {
            for c in &items[1..] {
                walk(ctx, c, lb, ub)?;
            }
            return Ok(());
        }
        if head == "at" {
            return Err(ctx.unsupported(sx.span(), "duration constraints at start or end"));
        }
        let [_, d, v] = items else {
            return Err(ctx.err(sx.span(), "expected `(= ?duration value)`"));
        };
        if d.atom() != Some("?duration") {
            return Err(ctx.err(
                d.span(),
                "the left side of a duration constraint must be `?duration`",
            ));
        }
        let v = expr(ctx, v)?;
        match head {
            "=" => {
                *lb = Some(v.clone());
                *ub = Some(v);
            }
            ">=" => *lb = Some(v),
            "<=" => *ub = Some(v),
            _ => {
                return Err(
                    ctx.unsupported(sx.span(), "strict duration inequalities (use `<=` or `>=`)")
                )
            }
        }
        Ok(())
    }
    walk(ctx, sx, &mut lb, &mut ub)?;
    Ok((lb.unwrap_or(Expr::Number(0.0)), ub))
}

fn durative_action(ctx: &Ctx<'_>, sx: &Sx) -> Result<DurativeAction, PddlError> {
    let items = ctx.list(sx, "a durative action")?;
    let name = items
        .get(1)
        .and_then(Sx::atom)
        .ok_or_else(|| ctx.err(sx.span(), "a durative action needs a name"))?
        .to_string();
    let mut action = DurativeAction {
        name,
        span: sx.span(),
        params: Vec::new(),
        duration: (Expr::Number(0.0), Some(Expr::Number(0.0))),
        duration_span: sx.span(),
        conditions: Vec::new(),
        effects: Vec::new(),
    };
    let mut has_duration = false;
    let mut i = 2;
    while i < items.len() {
        let key = ctx.atom(&items[i], "a keyword (`:parameters`, `:duration`, ...)")?;
        let Some(value) = items.get(i + 1) else {
            return Err(ctx.err(items[i].span(), format!("`{key}` needs a value")));
        };
        match key {
            ":parameters" => action.params = params(ctx, value)?,
            ":duration" => {
                action.duration = duration(ctx, value)?;
                action.duration_span = value.span();
                has_duration = true;
            }
            ":condition" => timed_conditions(ctx, value, &mut action.conditions)?,
            ":effect" => timed_effects(ctx, value, &mut action.effects)?,
            _ => {
                return Err(ctx.err(
                    items[i].span(),
                    format!("unknown durative-action field `{key}`"),
                ))
            }
        }
        i += 2;
    }
    if !has_duration {
        return Err(ctx.err(sx.span(), "a durative action needs a `:duration`"));
    }
    Ok(action)
}

/// Read a domain file's tree.
pub fn domain(ctx: &Ctx<'_>, sx: &Sx) -> Result<Domain, PddlError> {
    let items = ctx.list(sx, "`(define (domain NAME) ...)`")?;
    if sx.head() != Some("define") {
        return Err(ctx.err(
            sx.span(),
            "a domain file starts with `(define (domain NAME) ...)`",
        ));
    }
    let mut d = Domain::default();
    for section in &items[1..] {
        let s = ctx.list(section, "a domain section")?;
        let head = section.head().unwrap_or("");
        match head {
            "domain" => d.name = s.get(1).and_then(Sx::atom).unwrap_or("").to_string(),
            ":requirements" => {
                for r in &s[1..] {
                    let name = ctx.atom(r, "a requirement")?;
                    if !SUPPORTED_REQUIREMENTS.contains(&name) {
                        return Err(ctx.unsupported(r.span(), &format!("requirement `{name}`")));
                    }
                }
            }
            ":types" => {
                for (n, t, _) in typed_list(ctx, &s[1..])? {
                    d.types.push((n, t));
                }
            }
            ":constants" => {
                for (n, t, _) in typed_list(ctx, &s[1..])? {
                    d.constants.push((n, t));
                }
            }
            ":predicates" => {
                for p in &s[1..] {
                    d.predicates.push(signature(ctx, p)?);
                }
            }
            ":functions" => {
                let mut i = 1;
                while i < s.len() {
                    if s[i].atom() == Some("-") {
                        // `- number` after a function declaration.
                        if s.get(i + 1).and_then(Sx::atom) != Some("number") {
                            return Err(ctx.unsupported(
                                s[i].span(),
                                "functions of a type other than `number`",
                            ));
                        }
                        i += 2;
                        continue;
                    }
                    d.functions.push(signature(ctx, &s[i])?);
                    i += 1;
                }
            }
            ":modules" => {
                for m in &s[1..] {
                    let mi = ctx.list(m, "`(:module NAME (:function ...) ...)`")?;
                    if m.head() != Some(":module") {
                        return Err(ctx.err(m.span(), "expected `(:module NAME ...)`"));
                    }
                    let name = mi
                        .get(1)
                        .and_then(Sx::atom)
                        .ok_or_else(|| ctx.err(m.span(), "a module needs a name"))?;
                    let mut module = Module {
                        name: name.to_string(),
                        span: m.span(),
                        functions: Vec::new(),
                    };
                    for f in &mi[2..] {
                        let fi = ctx.list(f, "`(:function (NAME ?x - type ...))`")?;
                        if f.head() != Some(":function") || fi.len() != 2 {
                            return Err(
                                ctx.err(f.span(), "expected `(:function (NAME ?x - type ...))`")
                            );
                        }
                        module.functions.push(signature(ctx, &fi[1])?);
                    }
                    d.modules.push(module);
                }
            }
            ":durative-action" => d.actions.push(durative_action(ctx, section)?),
            ":action" => {
                return Err(ctx.unsupported(
                    section.span(),
                    "instantaneous actions (`:action`); write it as a `:durative-action`",
                ))
            }
            ":derived" => {
                return Err(ctx.unsupported(section.span(), "derived predicates (`:derived`)"))
            }
            ":constraints" => {
                return Err(
                    ctx.unsupported(section.span(), "trajectory constraints (`:constraints`)")
                )
            }
            ":process" | ":event" => {
                return Err(ctx.unsupported(section.span(), "processes and events (PDDL+)"))
            }
            _ => return Err(ctx.err(section.span(), format!("unknown domain section `{head}`"))),
        }
    }
    Ok(d)
}

/// Read a problem file's tree.
pub fn problem(ctx: &Ctx<'_>, sx: &Sx) -> Result<Problem, PddlError> {
    let items = ctx.list(sx, "`(define (problem NAME) ...)`")?;
    if sx.head() != Some("define") {
        return Err(ctx.err(
            sx.span(),
            "a problem file starts with `(define (problem NAME) ...)`",
        ));
    }
    let mut p = Problem::default();
    for section in &items[1..] {
        let s = ctx.list(section, "a problem section")?;
        let head = section.head().unwrap_or("");
        match head {
            "problem" => p.name = s.get(1).and_then(Sx::atom).unwrap_or("").to_string(),
            ":domain" => p.domain = s.get(1).and_then(Sx::atom).unwrap_or("").to_string(),
            ":requirements" => {}
            ":objects" => {
                for (n, t, _) in typed_list(ctx, &s[1..])? {
                    p.objects.push((n, t));
                }
            }
            ":init" => {
                for item in &s[1..] {
                    match item.head() {
                        Some("=") => {
                            let it = ctx.list(item, "`(= (f args) value)`")?;
                            let [_, f, v] = it else {
                                return Err(ctx.err(item.span(), "expected `(= (f args) value)`"));
                            };
                            let (function, args) = match f {
                                Sx::Atom(a, _) => (a.clone(), Vec::new()),
                                Sx::List(fi, _) => (
                                    fi.first()
                                        .and_then(Sx::atom)
                                        .ok_or_else(|| {
                                            ctx.err(f.span(), "expected a function name")
                                        })?
                                        .to_string(),
                                    fi[1..]
                                        .iter()
                                        .map(|a| term(ctx, a))
                                        .collect::<Result<_, _>>()?,
                                ),
                            };
                            p.init.push(InitItem::Value {
                                function,
                                args,
                                value: number(ctx, v)?,
                                span: item.span(),
                            });
                        }
                        Some("at")
                            if item
                                .list()
                                .and_then(|l| l.get(1))
                                .and_then(Sx::atom)
                                .is_some_and(|t| t.parse::<f64>().is_ok()) =>
                        {
                            let it = ctx.list(item, "`(at TIME literal)`")?;
                            let [_, t, lit] = it else {
                                return Err(ctx.err(item.span(), "expected `(at TIME literal)`"));
                            };
                            let time = number(ctx, t)?;
                            if time < 0.0 {
                                return Err(ctx.err(
                                    t.span(),
                                    "a timed initial literal's time must not be negative",
                                ));
                            }
                            let (positive, a) = if lit.head() == Some("not") {
                                let li = ctx.list(lit, "`(not atom)`")?;
                                (
                                    false,
                                    li.get(1).ok_or_else(|| {
                                        ctx.err(lit.span(), "`not` takes an atom")
                                    })?,
                                )
                            } else {
                                (true, lit)
                            };
                            if a.head() == Some("=") {
                                return Err(ctx.unsupported(
                                    item.span(),
                                    "timed initial fluents (numeric values at a time)",
                                ));
                            }
                            p.init.push(InitItem::Til {
                                time,
                                atom: atom(ctx, a)?,
                                positive,
                                span: item.span(),
                            });
                        }
                        Some("not") => {}
                        _ => p.init.push(InitItem::Atom(atom(ctx, item)?)),
                    }
                }
            }
            ":goal" => {
                let Some(g) = s.get(1) else {
                    return Err(ctx.err(section.span(), "`:goal` needs a condition"));
                };
                condition(ctx, g, &mut p.goal)?;
            }
            ":metric" => {
                let ok = s.get(1).and_then(Sx::atom) == Some("minimize")
                    && s.get(2).and_then(Sx::head) == Some("total-time");
                if !ok {
                    return Err(ctx.unsupported(
                        section.span(),
                        "metrics other than `(:metric minimize (total-time))`",
                    ));
                }
            }
            ":constraints" => {
                return Err(
                    ctx.unsupported(section.span(), "trajectory constraints (`:constraints`)")
                )
            }
            _ => return Err(ctx.err(section.span(), format!("unknown problem section `{head}`"))),
        }
    }
    Ok(p)
}
