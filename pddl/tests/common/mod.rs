//! Shared by the front end's tests: an independent plan validator, a way to plan a compiled
//! task with the `no_std` planner, and a small deterministic random generator.
//!
//! The validator works from the parsed domain and problem only (crate `pddl`'s parser): it
//! instantiates each plan action's schema with the plan's own arguments and simulates the
//! timed plan happening by happening (PDDL 2.1 semantics: at-start conditions before the
//! start, over-all conditions on every state strictly inside the action, at-end conditions
//! before the end, deletes before adds, timed initial literals as happenings, happenings at the
//! same time or closer than epsilon must not interfere, the goal at the end). It shares
//! nothing with the grounding, the binary task or the planner's own checks.
#![allow(dead_code)]

pub mod rover;

use std::collections::{HashMap, HashSet};

use pddl::ast::{self, Cmp, Condition, Domain, Effect, Expr, InitItem, NumOp, Problem, Term, When};

/// One action of a timed plan: start, `(name args...)`, duration, in PDDL time units.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    pub start: f64,
    pub action: String,
    pub duration: f64,
}

const TOLERANCE: f64 = 1e-6;

pub fn parse(domain: &str, problem: &str) -> (Domain, Problem) {
    let dctx = ast::Ctx {
        file: "domain",
        text: domain,
    };
    let pctx = ast::Ctx {
        file: "problem",
        text: problem,
    };
    let d = ast::domain(
        &dctx,
        &pddl::sexpr::read("domain", domain).expect("domain reads"),
    )
    .expect("domain parses");
    let p = ast::problem(
        &pctx,
        &pddl::sexpr::read("problem", problem).expect("problem reads"),
    )
    .expect("problem parses");
    (d, p)
}

/// A ground action instance: its schema and its arguments.
struct Instance<'d> {
    schema: &'d ast::DurativeAction,
    binding: HashMap<String, String>,
    start: f64,
    end: f64,
    duration: f64,
}

#[derive(Clone, Copy, PartialEq, Debug)]
enum Kind {
    Start,
    End,
    Til,
}

struct Event {
    time: f64,
    kind: Kind,
    /// The instance (Start/End) or the init item index (Til).
    index: usize,
}

#[derive(Default, Clone)]
struct State {
    atoms: HashSet<String>,
    values: HashMap<String, f64>,
}

fn ground_term(t: &Term, b: &HashMap<String, String>) -> String {
    match t {
        Term::Var(v) => b.get(v).cloned().unwrap_or_else(|| v.clone()),
        Term::Const(c) => c.clone(),
    }
}

fn ground_atom(a: &ast::Atom, b: &HashMap<String, String>) -> String {
    let mut s = a.pred.clone();
    for t in &a.args {
        s.push(' ');
        s.push_str(&ground_term(t, b));
    }
    s
}

fn ground_function(name: &str, args: &[Term], b: &HashMap<String, String>) -> String {
    let mut s = name.to_string();
    for t in args {
        s.push(' ');
        s.push_str(&ground_term(t, b));
    }
    s
}

fn eval(
    e: &Expr,
    b: &HashMap<String, String>,
    state: &State,
    duration: f64,
) -> Result<f64, String> {
    Ok(match e {
        Expr::Number(x) => *x,
        Expr::Duration => duration,
        Expr::Function(name, args, _) => {
            let key = ground_function(name, args, b);
            *state
                .values
                .get(&key)
                .ok_or_else(|| format!("({key}) has no value"))?
        }
        Expr::Binary(op, x, y) => {
            let (x, y) = (eval(x, b, state, duration)?, eval(y, b, state, duration)?);
            match op {
                '+' => x + y,
                '-' => x - y,
                '*' => x * y,
                '/' => x / y,
                other => return Err(format!("operator {other}")),
            }
        }
        Expr::Negate(x) => -eval(x, b, state, duration)?,
    })
}

fn holds(
    c: &Condition,
    b: &HashMap<String, String>,
    state: &State,
    duration: f64,
) -> Result<bool, String> {
    Ok(match c {
        Condition::Atom { atom, positive } => {
            state.atoms.contains(&ground_atom(atom, b)) == *positive
        }
        Condition::Equal {
            a,
            b: other,
            positive,
        } => (ground_term(a, b) == ground_term(other, b)) == *positive,
        Condition::Numeric { cmp, lhs, rhs, .. } => {
            let (l, r) = (
                eval(lhs, b, state, duration)?,
                eval(rhs, b, state, duration)?,
            );
            match cmp {
                Cmp::Ge => l >= r - TOLERANCE,
                Cmp::Le => l <= r + TOLERANCE,
                Cmp::Eq => (l - r).abs() <= TOLERANCE,
                Cmp::Gt => l > r + TOLERANCE,
                Cmp::Lt => l < r - TOLERANCE,
            }
        }
    })
}

/// What a happening's event reads and writes, for the interference check.
#[derive(Default)]
struct Footprint {
    reads: HashSet<String>,
    /// Invariants of an action ending here: only a delete at the same time interferes.
    guards: HashSet<String>,
    adds: HashSet<String>,
    dels: HashSet<String>,
}

fn expr_reads(e: &Expr, b: &HashMap<String, String>, out: &mut HashSet<String>) {
    match e {
        Expr::Function(name, args, _) => {
            out.insert(format!("#{}", ground_function(name, args, b)));
        }
        Expr::Binary(_, x, y) => {
            expr_reads(x, b, out);
            expr_reads(y, b, out);
        }
        Expr::Negate(x) => expr_reads(x, b, out),
        _ => {}
    }
}

pub struct Validator {
    domain: Domain,
    problem: Problem,
    /// Object -> every type it has.
    object_types: HashMap<String, HashSet<String>>,
    epsilon: f64,
}

impl Validator {
    pub fn new(domain_text: &str, problem_text: &str, epsilon: f64) -> Self {
        let (domain, problem) = parse(domain_text, problem_text);
        let ancestors = |ty: &str| {
            let mut out = HashSet::from(["object".to_string()]);
            let mut t = ty.to_string();
            for _ in 0..64 {
                out.insert(t.clone());
                match domain.types.iter().find(|(n, _)| *n == t) {
                    Some((_, p)) if *p != t => t = p.clone(),
                    _ => break,
                }
            }
            out
        };
        let object_types = problem
            .objects
            .iter()
            .chain(domain.constants.iter())
            .map(|(o, t)| (o.clone(), ancestors(t)))
            .collect();
        Self {
            domain,
            problem,
            object_types,
            epsilon,
        }
    }

    fn initial_state(&self) -> State {
        let mut s = State::default();
        let none = HashMap::new();
        for item in &self.problem.init {
            match item {
                InitItem::Atom(a) => {
                    s.atoms.insert(ground_atom(a, &none));
                }
                InitItem::Value {
                    function,
                    args,
                    value,
                    ..
                } => {
                    s.values
                        .insert(ground_function(function, args, &none), *value);
                }
                InitItem::Til { .. } => {}
            }
        }
        s
    }

    fn instance<'d>(&'d self, step: &Step) -> Result<Instance<'d>, String> {
        let inner = step
            .action
            .trim()
            .trim_start_matches('(')
            .trim_end_matches(')');
        let mut words = inner.split_whitespace();
        let name = words.next().ok_or("empty action")?;
        let args: Vec<&str> = words.collect();
        let schema = self
            .domain
            .actions
            .iter()
            .find(|a| a.name.eq_ignore_ascii_case(name))
            .ok_or_else(|| format!("no action named {name}"))?;
        if schema.params.len() != args.len() {
            return Err(format!(
                "{}: {} arguments for {} parameters",
                step.action,
                args.len(),
                schema.params.len()
            ));
        }
        let mut binding = HashMap::new();
        for (p, a) in schema.params.iter().zip(&args) {
            let types = self
                .object_types
                .get(*a)
                .ok_or_else(|| format!("{}: no object {a}", step.action))?;
            if !types.contains(&p.ty) {
                return Err(format!("{}: {a} is not a {}", step.action, p.ty));
            }
            binding.insert(p.name.clone(), a.to_string());
        }
        Ok(Instance {
            schema,
            binding,
            start: step.start,
            end: step.start + step.duration,
            duration: step.duration,
        })
    }

    fn footprint(
        &self,
        inst: Option<&Instance<'_>>,
        kind: Kind,
        til: Option<&InitItem>,
    ) -> Footprint {
        let mut f = Footprint::default();
        if let Some(InitItem::Til { atom, positive, .. }) = til {
            let g = ground_atom(atom, &HashMap::new());
            if *positive {
                f.adds.insert(g);
            } else {
                f.dels.insert(g);
            }
            return f;
        }
        let Some(i) = inst else { return f };
        let when = if kind == Kind::Start {
            When::Start
        } else {
            When::End
        };
        for (w, c) in &i.schema.conditions {
            if *w == When::OverAll {
                // An invariant starts with its action: a same-time effect on it interferes with
                // the start (as VAL has it); at the end only a same-time delete does.
                if let Condition::Atom { atom, .. } = c {
                    let g = ground_atom(atom, &i.binding);
                    if kind == Kind::Start {
                        f.reads.insert(g);
                    } else {
                        f.guards.insert(g);
                    }
                }
                continue;
            }
            if *w != when {
                continue;
            }
            match c {
                Condition::Atom { atom, .. } => {
                    f.reads.insert(ground_atom(atom, &i.binding));
                }
                Condition::Numeric { lhs, rhs, .. } => {
                    expr_reads(lhs, &i.binding, &mut f.reads);
                    expr_reads(rhs, &i.binding, &mut f.reads);
                }
                Condition::Equal { .. } => {}
            }
        }
        for (at_end, e) in &i.schema.effects {
            if *at_end != (kind == Kind::End) {
                continue;
            }
            match e {
                Effect::Add(a) => {
                    f.adds.insert(ground_atom(a, &i.binding));
                }
                Effect::Del(a) => {
                    f.dels.insert(ground_atom(a, &i.binding));
                }
                Effect::Numeric {
                    function,
                    args,
                    value,
                    ..
                } => {
                    let key = format!("#{}", ground_function(function, args, &i.binding));
                    f.dels.insert(key.clone());
                    f.adds.insert(key);
                    expr_reads(value, &i.binding, &mut f.reads);
                }
            }
        }
        f
    }

    /// Check `plan`; Err says what is wrong first.
    pub fn validate(&self, plan: &[Step]) -> Result<(), String> {
        let mut state = self.initial_state();
        let instances = plan
            .iter()
            .map(|s| self.instance(s))
            .collect::<Result<Vec<_>, _>>()?;
        for i in &instances {
            if i.duration < -TOLERANCE || i.start < -TOLERANCE {
                return Err(format!("{}: negative start or duration", i.schema.name));
            }
        }
        let mut events = Vec::new();
        for (k, i) in instances.iter().enumerate() {
            events.push(Event {
                time: i.start,
                kind: Kind::Start,
                index: k,
            });
            events.push(Event {
                time: i.end,
                kind: Kind::End,
                index: k,
            });
        }
        for (k, item) in self.problem.init.iter().enumerate() {
            if let InitItem::Til { time, .. } = item {
                events.push(Event {
                    time: *time,
                    kind: Kind::Til,
                    index: k,
                });
            }
        }
        // Starts before ends at equal times only matters for zero durations, which the
        // separation check refuses anyway.
        events.sort_by(|a, b| {
            a.time
                .partial_cmp(&b.time)
                .expect("finite times")
                .then((a.kind as u8).cmp(&(b.kind as u8)))
        });
        let mut groups: Vec<Vec<&Event>> = Vec::new();
        for e in &events {
            match groups.last_mut() {
                Some(g) if (e.time - g[0].time).abs() <= TOLERANCE => g.push(e),
                _ => groups.push(vec![e]),
            }
        }
        let footprint = |e: &Event| match e.kind {
            Kind::Til => self.footprint(None, Kind::Til, self.problem.init.get(e.index)),
            k => self.footprint(instances.get(e.index), k, None),
        };
        let interferes = |x: &Footprint, y: &Footprint| {
            x.dels.iter().any(|a| y.guards.contains(a))
                || y.dels.iter().any(|a| x.guards.contains(a))
                || x.dels
                    .iter()
                    .any(|a| y.reads.contains(a) || y.adds.contains(a))
                || x.adds
                    .iter()
                    .any(|a| y.reads.contains(a) || y.dels.contains(a))
                || y.dels
                    .iter()
                    .any(|a| x.reads.contains(a) || x.adds.contains(a))
                || y.adds
                    .iter()
                    .any(|a| x.reads.contains(a) || x.dels.contains(a))
        };
        for (gi, g) in groups.iter().enumerate() {
            let t = g[0].time;
            // Interference inside the happening and with the previous one if closer than epsilon.
            let prints: Vec<Footprint> = g.iter().map(|e| footprint(e)).collect();
            for x in 0..g.len() {
                for y in x + 1..g.len() {
                    if interferes(&prints[x], &prints[y]) {
                        return Err(format!("interfering happenings at time {t}"));
                    }
                }
            }
            if gi > 0 {
                let prev = &groups[gi - 1];
                if t - prev[0].time < self.epsilon - TOLERANCE {
                    for p in prev.iter() {
                        let pp = footprint(p);
                        if prints.iter().any(|x| interferes(x, &pp)) {
                            return Err(format!(
                                "interfering happenings closer than epsilon at {} and {t}",
                                prev[0].time
                            ));
                        }
                    }
                }
            }
            // Conditions and durations in the state before the happening.
            for e in g {
                if e.kind == Kind::Til {
                    continue;
                }
                let i = &instances[e.index];
                let when = if e.kind == Kind::Start {
                    When::Start
                } else {
                    When::End
                };
                for (w, c) in &i.schema.conditions {
                    if *w == when && !holds(c, &i.binding, &state, i.duration)? {
                        return Err(format!(
                            "{} ({:?} at {t}): condition {c:?} does not hold",
                            i.schema.name, e.kind
                        ));
                    }
                }
                if e.kind == Kind::Start {
                    let lb = eval(&i.schema.duration.0, &i.binding, &state, i.duration)?;
                    let ub = match &i.schema.duration.1 {
                        Some(x) => eval(x, &i.binding, &state, i.duration)?,
                        None => f64::INFINITY,
                    };
                    if i.duration < lb - 1e-3 || i.duration > ub + 1e-3 {
                        return Err(format!(
                            "{}: duration {} outside [{lb}, {ub}]",
                            i.schema.name, i.duration
                        ));
                    }
                }
            }
            // Effects: numeric values from the state before, deletes, then adds.
            let before = state.clone();
            let mut adds = Vec::new();
            for e in g {
                match e.kind {
                    Kind::Til => {
                        if let Some(InitItem::Til { atom, positive, .. }) =
                            self.problem.init.get(e.index)
                        {
                            let a = ground_atom(atom, &HashMap::new());
                            if *positive {
                                adds.push(a);
                            } else {
                                state.atoms.remove(&a);
                            }
                        }
                    }
                    k => {
                        let i = &instances[e.index];
                        for (at_end, eff) in &i.schema.effects {
                            if *at_end != (k == Kind::End) {
                                continue;
                            }
                            match eff {
                                Effect::Add(a) => adds.push(ground_atom(a, &i.binding)),
                                Effect::Del(a) => {
                                    state.atoms.remove(&ground_atom(a, &i.binding));
                                }
                                Effect::Numeric {
                                    op,
                                    function,
                                    args,
                                    value,
                                    ..
                                } => {
                                    let key = ground_function(function, args, &i.binding);
                                    let v = eval(value, &i.binding, &before, i.duration)?;
                                    let old = before.values.get(&key).copied();
                                    let new = match op {
                                        NumOp::Assign => v,
                                        NumOp::Increase => {
                                            old.ok_or(format!("({key}) undefined"))? + v
                                        }
                                        NumOp::Decrease => {
                                            old.ok_or(format!("({key}) undefined"))? - v
                                        }
                                    };
                                    state.values.insert(key, new);
                                }
                            }
                        }
                    }
                }
            }
            for a in adds {
                state.atoms.insert(a);
            }
            // Invariants of every action running on the interval after this happening.
            for i in &instances {
                if i.start <= t + TOLERANCE && t < i.end - TOLERANCE {
                    for (w, c) in &i.schema.conditions {
                        if *w == When::OverAll && !holds(c, &i.binding, &state, i.duration)? {
                            return Err(format!(
                                "{}: invariant {c:?} broken after time {t}",
                                i.schema.name
                            ));
                        }
                    }
                }
            }
        }
        for c in &self.problem.goal {
            if !holds(c, &HashMap::new(), &state, 0.0)? {
                return Err(format!("goal {c:?} does not hold at the end"));
            }
        }
        Ok(())
    }
}

/// What planning a compiled task gave.
pub struct Planned {
    pub status: temporal::Status,
    pub plan: Vec<Step>,
    pub makespan: f64,
    pub stats: temporal::Stats,
}

/// The planner's actions as the validator's steps, in PDDL time units (`tpu` ticks a unit).
pub fn steps_of(
    compiled: &pddl::Compiled,
    plan: &[temporal::PlannedAction],
    tpu: f64,
) -> Vec<Step> {
    plan.iter()
        .map(|s| Step {
            start: f64::from(s.start) / tpu,
            action: compiled.action_names[s.action as usize].clone(),
            duration: f64::from(s.duration) / tpu,
        })
        .collect()
}

/// Plan `compiled` natively in an arena of `arena_words` words, at most `max_expansions`.
pub fn plan(
    compiled: &pddl::Compiled,
    config: temporal::PlannerConfig,
    arena_words: usize,
    max_expansions: u64,
) -> Planned {
    plan_with(compiled, config, arena_words, max_expansions, |_| {})
}

/// [`plan`] with the planner set up by `set` first (e.g. the lookahead's searches).
pub fn plan_with(
    compiled: &pddl::Compiled,
    config: temporal::PlannerConfig,
    arena_words: usize,
    max_expansions: u64,
    set: impl FnOnce(&mut temporal::Planner<'_, '_>),
) -> Planned {
    let task = temporal::Task::parse(&compiled.task).expect("the front end writes a valid task");
    let tpu = f64::from(task.ticks_per_unit());
    let mut arena = vec![0u32; arena_words];
    let mut planner =
        temporal::Planner::new(task, &mut arena, config).expect("arena holds the tables");
    set(&mut planner);
    let status = loop {
        let s = planner.step(64);
        if s != temporal::Status::Searching || planner.stats().expanded >= max_expansions {
            break s;
        }
    };
    let mut plan = Vec::new();
    let mut makespan = 0.0;
    if status == temporal::Status::Solved {
        let mut out = vec![temporal::PlannedAction::default(); 4096];
        let (n, m) = planner.plan(&mut out).expect("a solved search has a plan");
        makespan = f64::from(m) / tpu;
        plan = steps_of(compiled, &out[..n], tpu);
    }
    Planned {
        status,
        plan,
        makespan,
        stats: planner.stats(),
    }
}

pub fn compile(domain: &str, problem: &str) -> Result<pddl::Compiled, pddl::PddlError> {
    compile_with(domain, problem, &pddl::Options::default())
}

/// [`compile`] with the front end's options.
pub fn compile_with(
    domain: &str,
    problem: &str,
    options: &pddl::Options,
) -> Result<pddl::Compiled, pddl::PddlError> {
    pddl::compile(
        pddl::Source {
            name: "domain.pddl",
            text: domain,
        },
        pddl::Source {
            name: "problem.pddl",
            text: problem,
        },
        &pddl::ModuleRegistry::new(),
        options,
    )
}

/// xorshift64*: the same numbers on every machine, no dependency.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
    pub fn chance(&mut self, percent: u64) -> bool {
        self.below(100) < percent
    }
}
