//! Grounding and translation: the parsed domain and problem to the planner's binary task.
//!
//! Grounding is by relaxed reachability, not the cross product: starting from the initial atoms
//! (and those timed initial literals add), each action schema's parameter choices are found by
//! joining its start's positive conditions (and invariants its start does not add) against the
//! atoms reachable so far; their start adds are added, and their end adds too once their end
//! conditions are reachable (which may need what their own start made reachable), until
//! nothing new is reachable. Actions whose end stays unreachable are dropped. Static predicates (no action or literal changes
//! them) are then compiled away, static functions (from the problem or from external modules)
//! are folded into durations and constants, and the remaining atoms and numeric terms become
//! the task's facts and numeric variables.
//!
//! Timed initial literals that make a fact true once and false once (or only one of the two),
//! on a fact no action changes, become global windows on the snap actions that need the fact
//! (section 4.4); the fact disappears from the state. Other timed literals are refused.
use std::collections::{BTreeMap, HashMap, HashSet};

use crate::ast::*;
use crate::modules::ModuleRegistry;
use crate::{Compiled, Options, PddlError};
use temporal::task::{self as format, ActionSpec, LinearSpec, UNBOUNDED};

type Obj = u32;
type Key = (u32, Vec<Obj>);
/// A numeric condition or effect for the binary task: (operator, target, terms, constant).
type NumericSpec = (u8, u16, Vec<(u16, i64)>, i64);

/// Context for errors in the two files.
pub struct Files<'a> {
    pub domain: Ctx<'a>,
    pub problem: Ctx<'a>,
}

struct World<'a> {
    _files: std::marker::PhantomData<&'a ()>,
    objects: Vec<String>,
    object_ids: HashMap<String, Obj>,
    /// Per object, every type it belongs to (its own and ancestors).
    object_types: Vec<HashSet<String>>,
    preds: HashMap<String, (u32, usize)>,
    pred_names: Vec<String>,
    fluent_preds: HashSet<u32>,
    /// Functions changed by some action.
    fluent_functions: HashSet<String>,
    function_arity: HashMap<String, usize>,
    /// Values of static functions (and initial values of fluent ones).
    values: HashMap<(String, Vec<Obj>), f64>,
}

fn ancestors(types: &[(String, String)], ty: &str) -> HashSet<String> {
    let mut out = HashSet::new();
    let mut t = ty.to_string();
    out.insert("object".to_string());
    for _ in 0..64 {
        if !out.insert(t.clone()) && t != "object" {
            break;
        }
        match types.iter().find(|(n, _)| *n == t) {
            Some((_, parent)) if parent != &t => t = parent.clone(),
            _ => break,
        }
    }
    out
}

impl<'a> World<'a> {
    fn objects_of(&self, ty: &str) -> Vec<Obj> {
        (0..self.objects.len() as Obj)
            .filter(|&o| self.object_types[o as usize].contains(ty))
            .collect()
    }
}

/// A binding of an action's parameters (object per parameter, u32::MAX while unbound).
type Binding = Vec<Obj>;
const UNBOUND: Obj = Obj::MAX;

/// A schema prepared for grounding.
struct Schema {
    params: Vec<Param>,
    /// Positive atoms a ground action's start needs reachable (start atoms, and over-all atoms
    /// its own start does not add): (pred, args as param index or object).
    needs: Vec<(u32, Vec<Arg>)>,
    /// Positive atoms its end needs besides (end atoms its own start does not add). They may
    /// become reachable only through what its start makes reachable, so they are checked per
    /// binding after the start's, not joined with them.
    end_needs: Vec<(u32, Vec<Arg>)>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Arg {
    Param(usize),
    Object(Obj),
}

fn resolve_term(
    w: &World<'_>,
    params: &[Param],
    t: &Term,
    ctx: &Ctx<'_>,
    span: &std::ops::Range<usize>,
) -> Result<Arg, PddlError> {
    match t {
        Term::Var(v) => params
            .iter()
            .position(|p| p.name == *v)
            .map(Arg::Param)
            .ok_or_else(|| {
                ctx.err(
                    span.clone(),
                    format!("`{v}` is not a parameter of this action"),
                )
            }),
        Term::Const(c) => w
            .object_ids
            .get(c)
            .map(|&o| Arg::Object(o))
            .ok_or_else(|| ctx.err(span.clone(), format!("unknown object or constant `{c}`"))),
    }
}

fn resolve_atom(
    w: &World<'_>,
    params: &[Param],
    a: &Atom,
    ctx: &Ctx<'_>,
) -> Result<(u32, Vec<Arg>), PddlError> {
    let Some(&(p, arity)) = w.preds.get(&a.pred) else {
        return Err(ctx.err(a.span.clone(), format!("unknown predicate `{}`", a.pred)));
    };
    if arity != a.args.len() {
        return Err(ctx.err(
            a.span.clone(),
            format!(
                "`{}` takes {arity} argument(s), given {}",
                a.pred,
                a.args.len()
            ),
        ));
    }
    let args = a
        .args
        .iter()
        .map(|t| resolve_term(w, params, t, ctx, &a.span))
        .collect::<Result<_, _>>()?;
    Ok((p, args))
}

fn bind(args: &[Arg], b: &Binding) -> Vec<Obj> {
    args.iter()
        .map(|a| match a {
            Arg::Param(i) => b[*i],
            Arg::Object(o) => *o,
        })
        .collect()
}

/// Every binding of `schema` whose needed atoms are in `reach` (indexed by predicate).
fn enumerate(
    w: &World<'_>,
    schema: &Schema,
    by_pred: &HashMap<u32, Vec<Vec<Obj>>>,
    check: &dyn Fn(&Binding) -> bool,
    out: &mut Vec<Binding>,
) {
    let mut b: Binding = vec![UNBOUND; schema.params.len()];
    let mut used = vec![false; schema.needs.len()];
    let domains: Vec<Vec<Obj>> = schema.params.iter().map(|p| w.objects_of(&p.ty)).collect();
    #[allow(clippy::too_many_arguments)] // a recursive helper over the enumeration state
    fn rec(
        w: &World<'_>,
        schema: &Schema,
        by_pred: &HashMap<u32, Vec<Vec<Obj>>>,
        domains: &[Vec<Obj>],
        b: &mut Binding,
        used: &mut [bool],
        check: &dyn Fn(&Binding) -> bool,
        out: &mut Vec<Binding>,
    ) {
        // The unused need with the most bound arguments, fewest candidates on ties.
        let mut best: Option<(usize, usize, usize)> = None;
        for (i, (p, args)) in schema.needs.iter().enumerate() {
            if used[i] {
                continue;
            }
            let bound = args
                .iter()
                .filter(|a| match a {
                    Arg::Param(k) => b[*k] != UNBOUND,
                    Arg::Object(_) => true,
                })
                .count();
            let cands = by_pred.get(p).map_or(0, Vec::len);
            let better = match best {
                None => true,
                Some((_, bb, bc)) => bound > bb || (bound == bb && cands < bc),
            };
            if better {
                best = Some((i, bound, cands));
            }
        }
        if let Some((i, _, _)) = best {
            used[i] = true;
            let (p, args) = &schema.needs[i];
            if let Some(cands) = by_pred.get(p) {
                'cand: for c in cands {
                    let mut newly = Vec::new();
                    for (a, &o) in args.iter().zip(c) {
                        match a {
                            Arg::Object(x) => {
                                if *x != o {
                                    for k in newly.drain(..) {
                                        b[k] = UNBOUND;
                                    }
                                    continue 'cand;
                                }
                            }
                            Arg::Param(k) => {
                                if b[*k] == UNBOUND {
                                    if !w.object_types[o as usize].contains(&schema.params[*k].ty) {
                                        for k in newly.drain(..) {
                                            b[k] = UNBOUND;
                                        }
                                        continue 'cand;
                                    }
                                    b[*k] = o;
                                    newly.push(*k);
                                } else if b[*k] != o {
                                    for k in newly.drain(..) {
                                        b[k] = UNBOUND;
                                    }
                                    continue 'cand;
                                }
                            }
                        }
                    }
                    rec(w, schema, by_pred, domains, b, used, check, out);
                    for k in newly {
                        b[k] = UNBOUND;
                    }
                }
            }
            used[i] = false;
            return;
        }
        // Parameters no condition binds range over their type.
        if let Some(k) = b.iter().position(|&x| x == UNBOUND) {
            for &o in &domains[k] {
                b[k] = o;
                rec(w, schema, by_pred, domains, b, used, check, out);
            }
            b[k] = UNBOUND;
            return;
        }
        if check(b) {
            out.push(b.clone());
        }
    }
    rec(w, schema, by_pred, &domains, &mut b, &mut used, check, out);
}

/// A linear expression over ground numeric variables with a constant (real numbers).
#[derive(Clone, Debug, Default)]
struct Lin {
    terms: BTreeMap<u32, f64>,
    constant: f64,
}

impl Lin {
    fn constant(x: f64) -> Self {
        Lin {
            terms: BTreeMap::new(),
            constant: x,
        }
    }
    fn scale(mut self, k: f64) -> Self {
        for v in self.terms.values_mut() {
            *v *= k;
        }
        self.constant *= k;
        self
    }
    fn add(mut self, other: Lin, sign: f64) -> Self {
        for (v, w) in other.terms {
            *self.terms.entry(v).or_insert(0.0) += sign * w;
        }
        self.constant += sign * other.constant;
        self
    }
}

fn fixed(x: f64) -> i64 {
    (x * format::NUMERIC_SCALE as f64).round() as i64
}

struct Grounder<'a, 'w> {
    w: &'w World<'a>,
    /// Ground fluent function terms to variable ids.
    vars: HashMap<(String, Vec<Obj>), u32>,
    var_names: Vec<String>,
}

impl Grounder<'_, '_> {
    fn obj_args(
        &self,
        params: &[Param],
        b: &Binding,
        args: &[Term],
        ctx: &Ctx<'_>,
        span: &std::ops::Range<usize>,
    ) -> Result<Vec<Obj>, PddlError> {
        args.iter()
            .map(|t| {
                resolve_term(self.w, params, t, ctx, span).map(|a| match a {
                    Arg::Param(i) => b[i],
                    Arg::Object(o) => o,
                })
            })
            .collect()
    }

    /// A numeric expression, linear in the fluent functions; `duration` is ?duration's value
    /// if allowed.
    fn linear(
        &mut self,
        e: &Expr,
        params: &[Param],
        b: &Binding,
        ctx: &Ctx<'_>,
        span: &std::ops::Range<usize>,
    ) -> Result<Lin, PddlError> {
        Ok(match e {
            Expr::Number(x) => Lin::constant(*x),
            Expr::Duration => {
                return Err(ctx.err(span.clone(), "unsupported PDDL feature: `?duration` in a condition or effect (effects that depend on the duration)"))
            }
            Expr::Negate(x) => self.linear(x, params, b, ctx, span)?.scale(-1.0),
            Expr::Function(f, args, fspan) => {
                let Some(&arity) = self.w.function_arity.get(f) else {
                    return Err(ctx.err(fspan.clone(), format!("unknown function `{f}`")));
                };
                if arity != args.len() {
                    return Err(ctx.err(fspan.clone(), format!("`{f}` takes {arity} argument(s), given {}", args.len())));
                }
                let objs = self.obj_args(params, b, args, ctx, fspan)?;
                let key = (f.clone(), objs);
                if self.w.fluent_functions.contains(f) {
                    let next = self.vars.len() as u32;
                    let id = *self.vars.entry(key.clone()).or_insert(next);
                    if id == next {
                        let names: Vec<&str> = key.1.iter().map(|&o| self.w.objects[o as usize].as_str()).collect();
                        self.var_names.push(format!("({} {})", f, names.join(" ")).replace(" )", ")"));
                    }
                    let mut l = Lin::default();
                    l.terms.insert(id, 1.0);
                    l
                } else {
                    match self.w.values.get(&key) {
                        Some(&x) => Lin::constant(x),
                        None => {
                            let names: Vec<&str> = key.1.iter().map(|&o| self.w.objects[o as usize].as_str()).collect();
                            return Err(ctx.err(fspan.clone(), format!("`({} {})` has no value in the problem", f, names.join(" "))));
                        }
                    }
                }
            }
            Expr::Binary(op, l, r) => {
                let l = self.linear(l, params, b, ctx, span)?;
                let r = self.linear(r, params, b, ctx, span)?;
                match op {
                    '+' => l.add(r, 1.0),
                    '-' => l.add(r, -1.0),
                    '*' if l.terms.is_empty() => r.scale(l.constant),
                    '*' if r.terms.is_empty() => l.scale(r.constant),
                    '/' if r.terms.is_empty() => {
                        if r.constant == 0.0 {
                            return Err(ctx.err(span.clone(), "division by zero"));
                        }
                        l.scale(1.0 / r.constant)
                    }
                    _ => return Err(ctx.err(span.clone(), "unsupported PDDL feature: non-linear numeric expressions")),
                }
            }
        })
    }
}

/// What one ground action is, before fact ids are final.
struct GroundAction {
    name: String,
    lb: u32,
    ub: u32,
    /// Fact keys per list, in [`format::FactList`] order.
    facts: [Vec<Key>; 7],
    numeric: [Vec<NumericSpec>; 5],
}

/// The ground actions that may take part in reaching `goals`, in their order: backward
/// relevance over the relaxed task. A fact is relevant if it is a goal or a condition (at
/// start, over all or at end) of a relevant action; an action is relevant if it adds a
/// relevant fact (at its start or its end) or has a numeric effect (kept whatever it changes:
/// numeric conditions are not traced). Conditions are positive only (the front end refuses
/// negative conditions on facts actions change), so deleting never helps: every valid plan
/// stays valid with its irrelevant actions taken out, and the planner loses no plan by never
/// seeing them. Nor does the search, which would otherwise generate, evaluate and propagate
/// through them on every state (satellite's images of directions no goal names, rovers'
/// samples nobody communicates).
fn relevant_actions(ground: Vec<GroundAction>, goals: &[Key]) -> Vec<GroundAction> {
    let relevant = relevance(&ground, goals);
    ground
        .into_iter()
        .zip(relevant)
        .filter_map(|(a, r)| r.then_some(a))
        .collect()
}

/// Per ground action: relevant (see [`relevant_actions`]).
fn relevance<'g>(ground: &'g [GroundAction], goals: &'g [Key]) -> Vec<bool> {
    let mut achievers: HashMap<&'g Key, Vec<usize>> = HashMap::new();
    for (i, a) in ground.iter().enumerate() {
        for k in a.facts[3].iter().chain(&a.facts[5]) {
            achievers.entry(k).or_default().push(i);
        }
    }
    let mut relevant = vec![false; ground.len()];
    let mut seen: HashSet<&'g Key> = HashSet::new();
    let mut todo: Vec<&'g Key> = Vec::new();
    let take = |i: usize, relevant: &mut Vec<bool>, todo: &mut Vec<&'g Key>| {
        if !relevant[i] {
            relevant[i] = true;
            todo.extend(ground[i].facts[..3].iter().flatten());
        }
    };
    for (i, a) in ground.iter().enumerate() {
        if !a.numeric[3].is_empty() || !a.numeric[4].is_empty() {
            take(i, &mut relevant, &mut todo);
        }
    }
    todo.extend(goals.iter());
    while let Some(k) = todo.pop() {
        if !seen.insert(k) {
            continue;
        }
        for &i in achievers.get(k).map_or(&[][..], Vec::as_slice) {
            take(i, &mut relevant, &mut todo);
        }
    }
    relevant
}

/// Ground `domain` + `problem` and write the task.
pub fn compile(
    files: &Files<'_>,
    domain: &Domain,
    problem: &Problem,
    modules: &ModuleRegistry,
    options: &Options,
) -> Result<Compiled, PddlError> {
    let (dctx, pctx) = (&files.domain, &files.problem);
    // Objects and their types.
    let mut all_types = domain.types.clone();
    for (_, t) in domain.constants.iter().chain(problem.objects.iter()) {
        if t != "object" && !all_types.iter().any(|(n, _)| n == t) {
            all_types.push((t.clone(), "object".into()));
        }
    }
    let mut w = World {
        _files: std::marker::PhantomData,
        objects: Vec::new(),
        object_ids: HashMap::new(),
        object_types: Vec::new(),
        preds: HashMap::new(),
        pred_names: Vec::new(),
        fluent_preds: HashSet::new(),
        fluent_functions: HashSet::new(),
        function_arity: HashMap::new(),
        values: HashMap::new(),
    };
    for (name, ty) in domain.constants.iter().chain(problem.objects.iter()) {
        if w.object_ids.contains_key(name) {
            continue;
        }
        w.object_ids.insert(name.clone(), w.objects.len() as Obj);
        w.objects.push(name.clone());
        w.object_types.push(ancestors(&all_types, ty));
    }
    for p in &domain.predicates {
        let id = w.pred_names.len() as u32;
        w.preds.insert(p.name.clone(), (id, p.params.len()));
        w.pred_names.push(p.name.clone());
    }
    for f in &domain.functions {
        w.function_arity.insert(f.name.clone(), f.params.len());
    }
    for m in &domain.modules {
        for f in &m.functions {
            w.function_arity.insert(f.name.clone(), f.params.len());
        }
    }
    if !problem.domain.is_empty() && !domain.name.is_empty() && problem.domain != domain.name {
        return Err(pctx.err(
            0..0,
            format!(
                "the problem is for domain `{}`, the domain file defines `{}`",
                problem.domain, domain.name
            ),
        ));
    }
    // Which predicates and functions change.
    for a in &domain.actions {
        for (_, e) in &a.effects {
            match e {
                Effect::Add(at) | Effect::Del(at) => {
                    if let Some(&(p, _)) = w.preds.get(&at.pred) {
                        w.fluent_preds.insert(p);
                    } else {
                        return Err(
                            dctx.err(at.span.clone(), format!("unknown predicate `{}`", at.pred))
                        );
                    }
                }
                Effect::Numeric { function, span, .. } => {
                    if !w.function_arity.contains_key(function) {
                        return Err(
                            dctx.err(span.clone(), format!("unknown function `{function}`"))
                        );
                    }
                    if domain
                        .modules
                        .iter()
                        .any(|m| m.functions.iter().any(|f| &f.name == function))
                    {
                        return Err(dctx.err(
                            span.clone(),
                            format!(
                                "`{function}` is an external function: actions cannot change it"
                            ),
                        ));
                    }
                    w.fluent_functions.insert(function.clone());
                }
            }
        }
    }
    let empty: Vec<Param> = Vec::new();
    // Initial state, values and timed literals.
    let mut init: HashSet<Key> = HashSet::new();
    let mut tils: Vec<(f64, Key, bool, std::ops::Range<usize>)> = Vec::new();
    for item in &problem.init {
        match item {
            InitItem::Atom(a) => {
                let (p, args) = resolve_atom(&w, &empty, a, pctx)?;
                init.insert((p, bind(&args, &Vec::new())));
            }
            InitItem::Value {
                function,
                args,
                value,
                span,
            } => {
                if !w.function_arity.contains_key(function) {
                    return Err(pctx.err(span.clone(), format!("unknown function `{function}`")));
                }
                let objs = args
                    .iter()
                    .map(|t| {
                        resolve_term(&w, &empty, t, pctx, span).map(|a| match a {
                            Arg::Object(o) => o,
                            Arg::Param(_) => 0,
                        })
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                w.values.insert((function.clone(), objs), *value);
            }
            InitItem::Til {
                time,
                atom,
                positive,
                span,
            } => {
                let (p, args) = resolve_atom(&w, &empty, atom, pctx)?;
                w.fluent_preds.insert(p);
                tils.push((
                    *time,
                    (p, bind(&args, &Vec::new())),
                    *positive,
                    span.clone(),
                ));
            }
        }
    }
    // External functions: evaluated on every parameter choice, now.
    for m in &domain.modules {
        let Some(module) = modules.get(&m.name) else {
            return Err(dctx.err(
                m.span.clone(),
                format!(
                    "no external module `{}` is registered (registered: {})",
                    m.name,
                    modules.names().join(", ")
                ),
            ));
        };
        for f in &m.functions {
            let domains: Vec<Vec<Obj>> = f.params.iter().map(|p| w.objects_of(&p.ty)).collect();
            let mut choice = vec![0usize; domains.len()];
            if domains.iter().any(Vec::is_empty) {
                continue;
            }
            loop {
                let objs: Vec<Obj> = choice.iter().zip(&domains).map(|(&i, d)| d[i]).collect();
                let names: Vec<&str> = objs
                    .iter()
                    .map(|&o| w.objects[o as usize].as_str())
                    .collect();
                let value = module.evaluate(&f.name, &names).map_err(|e| {
                    dctx.err(
                        f.span.clone(),
                        format!(
                            "external function `{}` of module `{}` failed on ({}): {e}",
                            f.name,
                            m.name,
                            names.join(" ")
                        ),
                    )
                })?;
                if !value.is_finite() {
                    return Err(dctx.err(
                        f.span.clone(),
                        format!(
                            "external function `{}` returned {value} on ({})",
                            f.name,
                            names.join(" ")
                        ),
                    ));
                }
                w.values.insert((f.name.clone(), objs), value);
                let mut k = 0;
                loop {
                    if k == choice.len() {
                        break;
                    }
                    choice[k] += 1;
                    if choice[k] < domains[k].len() {
                        break;
                    }
                    choice[k] = 0;
                    k += 1;
                }
                if k == choice.len() {
                    break;
                }
            }
        }
    }
    // Schemas.
    let mut schemas = Vec::new();
    for a in &domain.actions {
        let mut needs = Vec::new();
        let mut end_needs = Vec::new();
        let start_adds: Vec<(u32, Vec<Arg>)> = a
            .effects
            .iter()
            .filter_map(|(end, e)| match (end, e) {
                (false, Effect::Add(at)) => resolve_atom(&w, &a.params, at, dctx).ok(),
                _ => None,
            })
            .collect();
        for (when, c) in &a.conditions {
            if let Condition::Atom {
                atom,
                positive: true,
            } = c
            {
                let r = resolve_atom(&w, &a.params, atom, dctx)?;
                if *when != When::Start && start_adds.contains(&r) {
                    continue;
                }
                if *when == When::End {
                    end_needs.push(r);
                } else {
                    needs.push(r);
                }
            }
        }
        for p in &a.params {
            if p.ty != "object" && !all_types.iter().any(|(n, _)| *n == p.ty) {
                return Err(dctx.err(
                    a.span.clone(),
                    format!("unknown type `{}` of parameter `{}`", p.ty, p.name),
                ));
            }
        }
        schemas.push(Schema {
            params: a.params.clone(),
            needs,
            end_needs,
        });
    }
    // The static filter of a binding: equalities and negated static atoms.
    let static_ok = |a: &DurativeAction, b: &Binding| -> bool {
        a.conditions.iter().all(|(_, c)| match c {
            Condition::Equal {
                a: x,
                b: y,
                positive,
            } => {
                let rx = resolve_term(&w, &a.params, x, dctx, &a.span);
                let ry = resolve_term(&w, &a.params, y, dctx, &a.span);
                match (rx, ry) {
                    (Ok(x), Ok(y)) => (bind(&[x], b) == bind(&[y], b)) == *positive,
                    _ => false,
                }
            }
            Condition::Atom {
                atom,
                positive: false,
            } => match resolve_atom(&w, &a.params, atom, dctx) {
                Ok((p, args)) if !w.fluent_preds.contains(&p) => {
                    !init.contains(&(p, bind(&args, b)))
                }
                _ => true,
            },
            _ => true,
        })
    };
    // Reachability fixpoint.
    let mut reach: HashSet<Key> = init.clone();
    for (_, k, positive, _) in &tils {
        if *positive {
            reach.insert(k.clone());
        }
    }
    let mut bindings: Vec<Vec<Binding>> = vec![Vec::new(); schemas.len()];
    loop {
        let mut by_pred: HashMap<u32, Vec<Vec<Obj>>> = HashMap::new();
        for (p, args) in &reach {
            by_pred.entry(*p).or_default().push(args.clone());
        }
        for v in by_pred.values_mut() {
            v.sort();
        }
        let before = reach.len();
        for (i, (schema, action)) in schemas.iter().zip(&domain.actions).enumerate() {
            let mut out = Vec::new();
            enumerate(&w, schema, &by_pred, &|b| static_ok(action, b), &mut out);
            let mut complete = Vec::new();
            for b in out {
                let end_reachable = schema
                    .end_needs
                    .iter()
                    .all(|(p, args)| reach.contains(&(*p, bind(args, &b))));
                for (at_end, e) in &action.effects {
                    if let Effect::Add(at) = e {
                        if *at_end && !end_reachable {
                            continue;
                        }
                        let (p, args) = resolve_atom(&w, &action.params, at, dctx)?;
                        reach.insert((p, bind(&args, &b)));
                    }
                }
                if end_reachable {
                    complete.push(b);
                }
            }
            bindings[i] = complete;
        }
        if reach.len() == before {
            break;
        }
    }
    // Ground actions.
    let mut g = Grounder {
        w: &w,
        vars: HashMap::new(),
        var_names: Vec::new(),
    };
    let tpu = options.ticks_per_unit;
    let to_ticks =
        |x: f64| -> u32 { (x * tpu as f64).round().clamp(0.0, (UNBOUNDED - 1) as f64) as u32 };
    let mut ground: Vec<GroundAction> = Vec::new();
    for (action, bs) in domain.actions.iter().zip(&bindings) {
        'binding: for b in bs {
            let names: Vec<&str> = b.iter().map(|&o| w.objects[o as usize].as_str()).collect();
            let name = if names.is_empty() {
                format!("({})", action.name)
            } else {
                format!("({} {})", action.name, names.join(" "))
            };
            let lb_lin = g.linear(
                &action.duration.0,
                &action.params,
                b,
                dctx,
                &action.duration_span,
            )?;
            let ub_lin = match &action.duration.1 {
                Some(e) => Some(g.linear(e, &action.params, b, dctx, &action.duration_span)?),
                None => None,
            };
            if !lb_lin.terms.is_empty() || ub_lin.as_ref().is_some_and(|l| !l.terms.is_empty()) {
                return Err(dctx.err(action.duration_span.clone(), "unsupported PDDL feature: a duration that depends on a numeric fluent changed by actions"));
            }
            let lb = lb_lin.constant.max(0.0);
            let ub = ub_lin.map(|l| l.constant);
            if ub.is_some_and(|u| u < lb) {
                continue 'binding;
            }
            let mut ga = GroundAction {
                name,
                lb: to_ticks(lb),
                ub: ub.map_or(UNBOUNDED, to_ticks),
                facts: Default::default(),
                numeric: Default::default(),
            };
            for (when, c) in &action.conditions {
                match c {
                    Condition::Atom { atom, positive } => {
                        let (p, args) = resolve_atom(&w, &action.params, atom, dctx)?;
                        let key = (p, bind(&args, b));
                        if !w.fluent_preds.contains(&p) {
                            if init.contains(&key) != *positive {
                                continue 'binding;
                            }
                            continue;
                        }
                        if !positive {
                            return Err(dctx.err(atom.span.clone(), format!("unsupported PDDL feature: negative conditions on `{}`, which actions change", atom.pred)));
                        }
                        let list = match when {
                            When::Start => 0,
                            When::OverAll => 1,
                            When::End => 2,
                        };
                        if !ga.facts[list].contains(&key) {
                            ga.facts[list].push(key);
                        }
                    }
                    Condition::Equal { .. } => {}
                    Condition::Numeric {
                        cmp,
                        lhs,
                        rhs,
                        span,
                    } => {
                        let l = g.linear(lhs, &action.params, b, dctx, span)?;
                        let r = g.linear(rhs, &action.params, b, dctx, span)?;
                        let d = l.add(r, -1.0);
                        let Some(spec) = condition_spec(*cmp, &d) else {
                            continue 'binding;
                        };
                        let Some(spec) = spec else { continue };
                        let list = match when {
                            When::Start => 0,
                            When::OverAll => 1,
                            When::End => 2,
                        };
                        ga.numeric[list].push(spec);
                    }
                }
            }
            for (end, e) in &action.effects {
                let base = if *end { 5 } else { 3 };
                match e {
                    Effect::Add(at) => {
                        let (p, args) = resolve_atom(&w, &action.params, at, dctx)?;
                        let key = (p, bind(&args, b));
                        if !ga.facts[base].contains(&key) {
                            ga.facts[base].push(key);
                        }
                    }
                    Effect::Del(at) => {
                        let (p, args) = resolve_atom(&w, &action.params, at, dctx)?;
                        let key = (p, bind(&args, b));
                        if !ga.facts[base + 1].contains(&key) {
                            ga.facts[base + 1].push(key);
                        }
                    }
                    Effect::Numeric {
                        op,
                        function,
                        args,
                        value,
                        span,
                    } => {
                        let objs = g.obj_args(&action.params, b, args, dctx, span)?;
                        let target = g.linear(
                            &Expr::Function(function.clone(), args.clone(), span.clone()),
                            &action.params,
                            b,
                            dctx,
                            span,
                        )?;
                        let _ = objs;
                        let Some((&var, _)) = target.terms.iter().next() else {
                            return Err(dctx.err(
                                span.clone(),
                                "the target of a numeric effect must be a function",
                            ));
                        };
                        let v = g.linear(value, &action.params, b, dctx, span)?;
                        let kind = match op {
                            NumOp::Assign => format::EffectOp::Assign,
                            NumOp::Increase => format::EffectOp::Increase,
                            NumOp::Decrease => format::EffectOp::Decrease,
                        } as u8;
                        let terms = v
                            .terms
                            .iter()
                            .map(|(&k, &x)| (k as u16, fixed(x)))
                            .collect();
                        ga.numeric[if *end { 4 } else { 3 }].push((
                            kind,
                            var as u16,
                            terms,
                            fixed(v.constant),
                        ));
                    }
                }
            }
            // Delete-then-add: an atom both deleted and added at the same time stays true.
            for base in [3, 5] {
                let adds = ga.facts[base].clone();
                ga.facts[base + 1].retain(|k| !adds.contains(k));
            }
            ground.push(ga);
        }
    }
    // Timed initial literals: windows where the pattern allows.
    let touched: HashSet<&Key> = ground
        .iter()
        .flat_map(|a| a.facts[3..].iter().flatten())
        .collect();
    let eps = options.epsilon_ticks;
    let mut windows: HashMap<Key, (u32, u32)> = HashMap::new();
    let mut by_fact: BTreeMap<Key, Vec<(f64, bool, std::ops::Range<usize>)>> = BTreeMap::new();
    for (t, k, pos, span) in &tils {
        by_fact
            .entry(k.clone())
            .or_default()
            .push((*t, *pos, span.clone()));
    }
    let mut til_windows = 0usize;
    for (k, mut events) in by_fact {
        events.sort_by(|a, b| a.0.total_cmp(&b.0));
        let span = events[0].2.clone();
        let refuse = |why: &str| {
            pctx.err(span.clone(), format!("unsupported PDDL feature: timed initial literals on `{}` {why}; only one window (true once, false once) on a fact no action changes is supported", fact_name(&w, &k)))
        };
        if touched.contains(&k) {
            return Err(refuse("that actions also change"));
        }
        let initially = init.contains(&k);
        let window = match (initially, events.as_slice()) {
            (true, [(t, false, _)]) => (0, to_ticks(*t).saturating_sub(eps)),
            (false, [(t, true, _)]) => (to_ticks(*t).saturating_add(eps), UNBOUNDED),
            (false, [(t1, true, _), (t2, false, _)]) if t2 > t1 => (
                to_ticks(*t1).saturating_add(eps),
                to_ticks(*t2).saturating_sub(eps),
            ),
            (true, [(_, true, _), ..]) | (false, [(_, false, _), ..]) => {
                return Err(refuse("that repeat the fact's value"))
            }
            _ => return Err(refuse("that open or close more than one window")),
        };
        windows.insert(k, window);
        til_windows += 1;
    }
    // Facts: every atom some action or the goal names, minus the window facts.
    let mut fact_ids: BTreeMap<Key, u16> = BTreeMap::new();
    let mut goal_keys = Vec::new();
    let mut goal_conditions = Vec::new();
    for c in &problem.goal {
        match c {
            Condition::Atom { atom, positive } => {
                let (p, args) = resolve_atom(&w, &empty, atom, pctx)?;
                let key = (p, bind(&args, &Vec::new()));
                if !positive {
                    return Err(pctx.err(
                        atom.span.clone(),
                        "unsupported PDDL feature: negative goals",
                    ));
                }
                if windows.contains_key(&key) {
                    return Err(pctx.err(atom.span.clone(), "unsupported PDDL feature: a goal on a fact that timed initial literals control"));
                }
                if !w.fluent_preds.contains(&p) && !init.contains(&key) {
                    return Err(pctx.err(atom.span.clone(), "this goal can never hold: its predicate is static and the atom is not in the initial state"));
                }
                if w.fluent_preds.contains(&p) {
                    goal_keys.push(key);
                }
            }
            Condition::Equal { .. } => {
                return Err(pctx.err(0..0, "unsupported PDDL feature: equality in goals"))
            }
            Condition::Numeric {
                cmp,
                lhs,
                rhs,
                span,
            } => {
                let l = g.linear(lhs, &empty, &Vec::new(), pctx, span)?;
                let r = g.linear(rhs, &empty, &Vec::new(), pctx, span)?;
                match condition_spec(*cmp, &l.add(r, -1.0)) {
                    None => return Err(pctx.err(span.clone(), "this numeric goal can never hold")),
                    Some(None) => {}
                    Some(Some(spec)) => goal_conditions.push(spec),
                }
            }
        }
    }
    if options.prune_irrelevant {
        ground = relevant_actions(ground, &goal_keys);
    }
    let mut keys: Vec<&Key> = ground
        .iter()
        .flat_map(|a| a.facts.iter().flatten())
        .collect();
    keys.extend(goal_keys.iter());
    for k in keys {
        if windows.contains_key(k) {
            continue;
        }
        let next = fact_ids.len();
        if next >= format::MAX_IDS - 1 {
            return Err(pctx.err(
                0..0,
                "the grounded task has more facts than the planner can index (65534)",
            ));
        }
        fact_ids.entry(k.clone()).or_insert(next as u16);
    }
    // Renumber facts in a deterministic order (sorted by key).
    let sorted: Vec<Key> = fact_ids.keys().cloned().collect();
    for (i, k) in sorted.iter().enumerate() {
        fact_ids.insert(k.clone(), i as u16);
    }
    let fid = |k: &Key| fact_ids[k];
    // Actions, with the window facts turned into bounds.
    let mut specs_facts: Vec<[Vec<u16>; 7]> = Vec::new();
    let mut specs_windows = Vec::new();
    for a in &ground {
        let mut lists: [Vec<u16>; 7] = Default::default();
        let (mut sw, mut ew) = ((0u32, UNBOUNDED), (0u32, UNBOUNDED));
        for (i, list) in a.facts.iter().enumerate() {
            for k in list {
                if let Some(&(lo, hi)) = windows.get(k) {
                    let narrow = |w: &mut (u32, u32)| {
                        w.0 = w.0.max(lo);
                        w.1 = w.1.min(hi);
                    };
                    match i {
                        0 => narrow(&mut sw),
                        1 => {
                            narrow(&mut sw);
                            narrow(&mut ew);
                        }
                        _ => narrow(&mut ew),
                    }
                    continue;
                }
                lists[i].push(fid(k));
            }
        }
        specs_facts.push(lists);
        specs_windows.push((sw, ew));
    }
    // Drop actions whose window is empty.
    let keep: Vec<usize> = (0..ground.len())
        .filter(|&i| {
            specs_windows[i].0 .0 <= specs_windows[i].0 .1
                && specs_windows[i].1 .0 <= specs_windows[i].1 .1
        })
        .collect();
    if keep.len() >= format::MAX_IDS - 1 {
        return Err(pctx.err(
            0..0,
            format!(
                "the grounded task has {} actions; the planner indexes at most 65534",
                keep.len()
            ),
        ));
    }
    // Numeric variables and initial values.
    let nvars = g.vars.len();
    let mut initial_values = vec![0i64; nvars];
    for ((f, objs), &id) in &g.vars {
        match w.values.get(&(f.clone(), objs.clone())) {
            Some(&x) => initial_values[id as usize] = fixed(x),
            None => {
                return Err(pctx.err(
                    0..0,
                    format!(
                        "the numeric fluent {} has no initial value in the problem",
                        g.var_names[id as usize]
                    ),
                ))
            }
        }
    }
    let initial_facts: Vec<u16> = init
        .iter()
        .filter_map(|k| fact_ids.get(k).copied())
        .collect();
    let goal_facts: Vec<u16> = goal_keys.iter().map(fid).collect();
    // Write.
    let numeric_specs: Vec<[Vec<NumericSpec>; 5]> =
        keep.iter().map(|&i| ground[i].numeric.clone()).collect();
    let lin_specs: Vec<[Vec<LinearSpec<'_>>; 5]> = numeric_specs
        .iter()
        .map(|n| {
            let mut out: [Vec<LinearSpec<'_>>; 5] = Default::default();
            for (i, list) in n.iter().enumerate() {
                out[i] = list
                    .iter()
                    .map(|(kind, target, terms, constant)| LinearSpec {
                        kind: *kind,
                        target: *target,
                        terms,
                        constant: *constant,
                    })
                    .collect();
            }
            out
        })
        .collect();
    let goal_specs: Vec<LinearSpec<'_>> = goal_conditions
        .iter()
        .map(|(kind, _, terms, constant)| LinearSpec {
            kind: *kind,
            target: 0,
            terms,
            constant: *constant,
        })
        .collect();
    let action_specs: Vec<ActionSpec<'_>> = keep
        .iter()
        .enumerate()
        .map(|(j, &i)| {
            let f = &specs_facts[i];
            let n = &lin_specs[j];
            ActionSpec {
                name: &ground[i].name,
                duration_lb: ground[i].lb,
                duration_ub: ground[i].ub,
                start_window: specs_windows[i].0,
                end_window: specs_windows[i].1,
                facts: [&f[0], &f[1], &f[2], &f[3], &f[4], &f[5], &f[6]],
                numeric: [&n[0], &n[1], &n[2], &n[3], &n[4]],
            }
        })
        .collect();
    let mut bytes = Vec::new();
    format::write_task(
        &mut |b| bytes.extend_from_slice(b),
        fact_ids.len() as u16,
        nvars as u16,
        eps,
        tpu,
        &initial_facts,
        &initial_values,
        &goal_facts,
        &goal_specs,
        &action_specs,
    );
    let fact_names = sorted.iter().map(|k| fact_name(&w, k)).collect();
    Ok(Compiled {
        task: bytes,
        action_names: keep.iter().map(|&i| ground[i].name.clone()).collect(),
        fact_names,
        numeric_names: g.var_names.clone(),
        til_windows,
        ticks_per_unit: tpu,
        epsilon_ticks: eps,
    })
}

fn fact_name(w: &World<'_>, k: &Key) -> String {
    let mut s = format!("({}", w.pred_names[k.0 as usize]);
    for &o in &k.1 {
        s.push(' ');
        s.push_str(&w.objects[o as usize]);
    }
    s.push(')');
    s
}

/// `d cmp 0` as a condition spec; None if it can never hold, Some(None) if it always holds.
#[allow(clippy::type_complexity)]
fn condition_spec(cmp: Cmp, d: &Lin) -> Option<Option<(u8, u16, Vec<(u16, i64)>, i64)>> {
    let one = 1.0 / format::NUMERIC_SCALE as f64;
    let (kind, constant) = match cmp {
        Cmp::Ge => (format::Comparison::AtLeast, d.constant),
        Cmp::Gt => (format::Comparison::AtLeast, d.constant - one),
        Cmp::Le => (format::Comparison::AtMost, d.constant),
        Cmp::Lt => (format::Comparison::AtMost, d.constant + one),
        Cmp::Eq => (format::Comparison::Equal, d.constant),
    };
    let terms: Vec<(u16, i64)> = d
        .terms
        .iter()
        .filter(|(_, &w)| w != 0.0)
        .map(|(&v, &w)| (v as u16, fixed(w)))
        .collect();
    if terms.is_empty() {
        let c = fixed(constant);
        let holds = match kind {
            format::Comparison::AtLeast => c >= 0,
            format::Comparison::AtMost => c <= 0,
            format::Comparison::Equal => c == 0,
        };
        return if holds { Some(None) } else { None };
    }
    Some(Some((kind as u8, 0, terms, fixed(constant))))
}
