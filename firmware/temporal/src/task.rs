//! The compact binary planning task: what the host's PDDL front end writes and the planner
//! reads. [`Task::parse`] validates every count, index and bound once, at the boundary; after
//! that the accessors cannot go out of range, and bad bytes are a [`TaskError`], never a panic.
//!
//! Layout (all integers little-endian):
//!
//! ```text
//! header (28 bytes)
//!   magic "STLR", version u16, fact count u16, numeric variable count u16, action count u16,
//!   epsilon u32 (ticks), ticks per PDDL time unit u32, goal fact count u16,
//!   goal condition count u16, names offset u32
//! initial facts        bitset, ceil(facts / 8) bytes, fact f is bit f % 8 of byte f / 8
//! initial numerics     i64 per variable, fixed point (NUMERIC_SCALE per unit)
//! goal facts           u16 each
//! goal conditions      NumericCondition each
//! action offsets       u32 per action: byte offset of its record from the start of the task
//! action records       see below
//! names                per action: u16 length, then that many bytes of UTF-8 (for printing)
//! ```
//!
//! An action record: duration lower bound u32 and upper bound u32 (ticks, [`UNBOUNDED`] for
//! none); the start's window lo u32, hi u32 and the end's window lo u32, hi u32 (global bounds
//! from timed initial literals, [`UNBOUNDED`] hi for none); seven fact lists, each a u16 count
//! then u16 fact ids, in the order of [`FactList`]; then u8 counts and records of numeric
//! conditions at start, over all and at end, and numeric effects at start and at end.
//!
//! A numeric condition: comparison u8 ([`Comparison`]), term count u8, constant i64, then terms
//! (variable u16, weight i64): it holds when `sum(weight * value) / NUMERIC_SCALE + constant`
//! compares with zero as asked. A numeric effect: operation u8 ([`EffectOp`]), target
//! variable u16, term count u8, constant i64, terms as above.
#![deny(clippy::indexing_slicing)]

/// The first four bytes of every task.
pub const MAGIC: [u8; 4] = *b"STLR";
/// The format version this crate reads.
pub const VERSION: u16 = 1;
/// Bytes of the fixed header.
pub const HEADER_BYTES: usize = 28;
/// A time bound meaning "none" (an unbounded duration or window).
pub const UNBOUNDED: u32 = u32::MAX;
/// Fixed-point scale of numeric values: 1.0 is 1000.
pub const NUMERIC_SCALE: i64 = 1000;
/// Most facts, numeric variables and actions a task may have (ids are u16; one is spare).
pub const MAX_IDS: usize = u16::MAX as usize;

/// The seven fact lists of an action, in their order in the record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum FactList {
    PreStart = 0,
    Invariant = 1,
    PreEnd = 2,
    AddStart = 3,
    DelStart = 4,
    AddEnd = 5,
    DelEnd = 6,
}

/// The five numeric lists of an action, in their order in the record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum NumericList {
    CondStart = 0,
    CondInvariant = 1,
    CondEnd = 2,
    EffStart = 3,
    EffEnd = 4,
}

/// How a numeric condition's left side compares with zero.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Comparison {
    AtLeast = 0,
    AtMost = 1,
    Equal = 2,
}

/// What a numeric effect does to its target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum EffectOp {
    Assign = 0,
    Increase = 1,
    Decrease = 2,
}

/// Why a task was refused; `offset` is the byte where reading stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TaskError {
    pub offset: usize,
    pub kind: TaskErrorKind,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TaskErrorKind {
    BadMagic,
    UnsupportedVersion,
    Truncated,
    FactOutOfRange,
    VariableOutOfRange,
    BadComparison,
    BadEffectOp,
    DurationBoundsReversed,
    WindowReversed,
    OffsetOutOfRange,
    TooMany,
    BadName,
    ZeroEpsilon,
}

impl core::fmt::Display for TaskError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "bad planning task at byte {}: {:?}",
            self.offset, self.kind
        )
    }
}

/// A little-endian reader over the task bytes that reports where it ran out.
#[derive(Clone, Copy)]
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn err(&self, kind: TaskErrorKind) -> TaskError {
        TaskError {
            offset: self.at,
            kind,
        }
    }
    fn take<const N: usize>(&mut self) -> Result<[u8; N], TaskError> {
        let end = self
            .at
            .checked_add(N)
            .ok_or(self.err(TaskErrorKind::Truncated))?;
        let slice = self
            .bytes
            .get(self.at..end)
            .ok_or(self.err(TaskErrorKind::Truncated))?;
        let mut out = [0u8; N];
        out.copy_from_slice(slice);
        self.at = end;
        Ok(out)
    }
    fn u8(&mut self) -> Result<u8, TaskError> {
        Ok(self.take::<1>()?[0])
    }
    fn u16(&mut self) -> Result<u16, TaskError> {
        Ok(u16::from_le_bytes(self.take()?))
    }
    fn u32(&mut self) -> Result<u32, TaskError> {
        Ok(u32::from_le_bytes(self.take()?))
    }
    fn i64(&mut self) -> Result<i64, TaskError> {
        Ok(i64::from_le_bytes(self.take()?))
    }
    fn skip(&mut self, n: usize) -> Result<(), TaskError> {
        let end = self
            .at
            .checked_add(n)
            .ok_or(self.err(TaskErrorKind::Truncated))?;
        if end > self.bytes.len() {
            return Err(self.err(TaskErrorKind::Truncated));
        }
        self.at = end;
        Ok(())
    }
}

fn read_u16(bytes: &[u8], at: usize) -> u16 {
    match bytes.get(at..at + 2) {
        Some(&[a, b]) => u16::from_le_bytes([a, b]),
        _ => 0,
    }
}

fn read_u32(bytes: &[u8], at: usize) -> u32 {
    match bytes.get(at..at + 4) {
        Some(&[a, b, c, d]) => u32::from_le_bytes([a, b, c, d]),
        _ => 0,
    }
}

fn read_i64(bytes: &[u8], at: usize) -> i64 {
    let mut out = [0u8; 8];
    if let Some(s) = bytes.get(at..at + 8) {
        out.copy_from_slice(s);
    }
    i64::from_le_bytes(out)
}

/// A validated planning task over its bytes.
#[derive(Clone, Copy)]
pub struct Task<'a> {
    bytes: &'a [u8],
    /// Where [`Task::parse`] found the parts; `layout.len` is `bytes.len()`.
    layout: TaskLayout,
}

/// Where [`Task::parse`] found a task's parts: kept by a caller that holds the same bytes
/// unchanged, to take the task up again without validating it anew ([`Task::from_layout`]).
/// Every field is an integer, so all-zero bytes are a valid layout (of no task: it matches no
/// bytes but an empty slice, which no task is).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TaskLayout {
    len: usize,
    facts: usize,
    numerics: usize,
    actions: usize,
    epsilon: u32,
    ticks_per_unit: u32,
    goal_facts: usize,
    goal_conditions: usize,
    init_facts_at: usize,
    init_numerics_at: usize,
    goal_facts_at: usize,
    goal_conditions_at: usize,
    offsets_at: usize,
    names_at: usize,
}

impl<'a> Task<'a> {
    /// The layout [`Self::from_layout`] takes.
    pub fn layout(&self) -> TaskLayout {
        self.layout
    }

    /// The task over `bytes` that [`Self::parse`] validated before, without validating it
    /// again: the caller keeps the bytes unchanged since (the planner partition's task buffer,
    /// which nothing writes while the task is in use). None if the length differs or the
    /// layout is empty. Reading a task whose bytes did change afterwards gives wrong answers,
    /// never a panic (every read of a task is bounds-checked).
    pub fn from_layout(bytes: &'a [u8], layout: &TaskLayout) -> Option<Self> {
        if bytes.len() != layout.len || layout.len == 0 || layout.epsilon == 0 {
            return None;
        }
        Some(Self {
            bytes,
            layout: *layout,
        })
    }
}

/// A list of u16 fact ids inside the task: its bytes, sliced once, so that reading an id
/// checks no bounds (the search reads these lists for every successor it tries; reading each
/// id through a bounds-checked offset was a fifth of an expansion's instructions on the
/// PowerPC 750, rovers 17).
#[derive(Clone, Copy)]
pub struct Facts<'a> {
    list: &'a [[u8; 2]],
}

impl<'a> Facts<'a> {
    /// The `len` ids from byte `at` of `bytes` (none if they are not all inside: a validated
    /// task's lists always are).
    fn new(bytes: &'a [u8], at: usize, len: usize) -> Self {
        let list = at
            .checked_add(2 * len)
            .and_then(|end| bytes.get(at..end))
            .unwrap_or(&[]);
        Facts {
            list: list.as_chunks::<2>().0,
        }
    }
    pub fn len(&self) -> usize {
        self.list.len()
    }
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }
    pub fn get(&self, i: usize) -> u16 {
        self.list.get(i).map_or(0, |&b| u16::from_le_bytes(b))
    }
    pub fn iter(&self) -> impl Iterator<Item = usize> + 'a {
        self.list.iter().map(|&b| u16::from_le_bytes(b) as usize)
    }
    pub fn contains(&self, fact: usize) -> bool {
        self.iter().any(|f| f == fact)
    }
}

/// One linear numeric condition or effect inside the task.
#[derive(Clone, Copy)]
pub struct Linear<'a> {
    bytes: &'a [u8],
    /// Offset of the first term.
    terms_at: usize,
    pub terms: usize,
    pub constant: i64,
    /// The comparison (conditions) or operation (effects) byte.
    pub kind: u8,
    /// The target variable (effects only).
    pub target: usize,
}

impl<'a> Linear<'a> {
    pub fn term(&self, i: usize) -> (usize, i64) {
        let at = self.terms_at + 10 * i;
        (
            read_u16(self.bytes, at) as usize,
            read_i64(self.bytes, at + 2),
        )
    }
    pub fn term_vars(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.terms).map(move |i| self.term(i).0)
    }
    /// `sum(weight * value) / NUMERIC_SCALE + constant`, or None on overflow.
    pub fn evaluate(&self, values: &dyn Fn(usize) -> i64) -> Option<i64> {
        let mut sum: i128 = 0;
        for i in 0..self.terms {
            let (v, w) = self.term(i);
            sum = sum.checked_add(i128::from(w) * i128::from(values(v)))?;
        }
        let scaled = sum / i128::from(NUMERIC_SCALE) + i128::from(self.constant);
        i64::try_from(scaled).ok()
    }
    /// Whether this condition holds for the values.
    pub fn holds(&self, values: &dyn Fn(usize) -> i64) -> bool {
        let Some(x) = self.evaluate(values) else {
            return false;
        };
        match self.kind {
            0 => x >= 0,
            1 => x <= 0,
            _ => x == 0,
        }
    }
    /// The new value of the target after this effect, or None on overflow.
    pub fn apply(&self, values: &dyn Fn(usize) -> i64) -> Option<i64> {
        let x = self.evaluate(values)?;
        let old = values(self.target);
        match self.kind {
            0 => Some(x),
            1 => old.checked_add(x),
            _ => old.checked_sub(x),
        }
    }
}

/// One action's record.
#[derive(Clone, Copy)]
pub struct Action<'a> {
    bytes: &'a [u8],
    pub duration_lb: u32,
    pub duration_ub: u32,
    pub start_window: (u32, u32),
    pub end_window: (u32, u32),
    lists: [Facts<'a>; 7],
    /// Offset of the numeric section (five counted lists of linear records).
    numeric_at: usize,
}

impl<'a> Action<'a> {
    pub fn facts(&self, list: FactList) -> Facts<'a> {
        self.lists
            .get(list as usize)
            .copied()
            .unwrap_or(Facts { list: &[] })
    }
    /// Where numeric list `i` starts and how many records it has.
    fn numeric_list(&self, i: usize) -> (usize, usize) {
        let mut p = self.numeric_at;
        for k in 0..5 {
            let n = self.bytes.get(p).copied().unwrap_or(0) as usize;
            p += 1;
            if k == i {
                return (p, n);
            }
            for _ in 0..n {
                p = linear_at(self.bytes, p, k >= 3).1;
            }
        }
        (p, 0)
    }
    /// The numeric conditions or effects of one list.
    pub fn numeric(&self, list: NumericList) -> impl Iterator<Item = Linear<'a>> + 'a {
        let i = list as usize;
        let effect = matches!(list, NumericList::EffStart | NumericList::EffEnd);
        let (mut at, n) = self.numeric_list(i);
        let bytes = self.bytes;
        (0..n).map(move |_| {
            let (lin, next) = linear_at(bytes, at, effect);
            at = next;
            lin
        })
    }
    pub fn has_numeric(&self, list: NumericList) -> bool {
        self.numeric_list(list as usize).1 > 0
    }
    /// Whether the action has any numeric condition or effect.
    pub fn has_any_numeric(&self) -> bool {
        (0..5).any(|i| self.numeric_list(i).1 > 0)
    }
}

/// Read a linear record at `at` (already validated) and the offset after it.
fn linear_at(bytes: &[u8], at: usize, effect: bool) -> (Linear<'_>, usize) {
    let kind = bytes.get(at).copied().unwrap_or(0);
    let (target, at) = if effect {
        (read_u16(bytes, at + 1) as usize, at + 3)
    } else {
        (0, at + 1)
    };
    let terms = bytes.get(at).copied().unwrap_or(0) as usize;
    let constant = read_i64(bytes, at + 1);
    let terms_at = at + 9;
    (
        Linear {
            bytes,
            terms_at,
            terms,
            constant,
            kind,
            target,
        },
        terms_at + 10 * terms,
    )
}

impl<'a> Task<'a> {
    /// Validate `bytes` as a task.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, TaskError> {
        use TaskErrorKind::*;
        let mut c = Cursor { bytes, at: 0 };
        if c.take::<4>()? != MAGIC {
            return Err(TaskError {
                offset: 0,
                kind: BadMagic,
            });
        }
        if c.u16()? != VERSION {
            return Err(c.err(UnsupportedVersion));
        }
        let facts = c.u16()? as usize;
        let numerics = c.u16()? as usize;
        let actions = c.u16()? as usize;
        let epsilon = c.u32()?;
        if epsilon == 0 {
            return Err(c.err(ZeroEpsilon));
        }
        let ticks_per_unit = c.u32()?;
        let goal_facts = c.u16()? as usize;
        let goal_conditions = c.u16()? as usize;
        let names_at = c.u32()? as usize;
        if facts >= MAX_IDS || numerics >= MAX_IDS || actions >= MAX_IDS {
            return Err(c.err(TooMany));
        }
        let init_facts_at = c.at;
        c.skip(facts.div_ceil(8))?;
        let init_numerics_at = c.at;
        c.skip(numerics * 8)?;
        let goal_facts_at = c.at;
        for _ in 0..goal_facts {
            if c.u16()? as usize >= facts {
                return Err(c.err(FactOutOfRange));
            }
        }
        let goal_conditions_at = c.at;
        for _ in 0..goal_conditions {
            check_linear(&mut c, numerics, false)?;
        }
        let offsets_at = c.at;
        let mut offsets = c;
        c.skip(actions * 4)?;
        let mut end_of_records = c.at;
        for _ in 0..actions {
            let at = offsets.u32()? as usize;
            if at < c.at || at >= bytes.len() {
                return Err(offsets.err(OffsetOutOfRange));
            }
            let mut r = Cursor { bytes, at };
            check_action(&mut r, facts, numerics)?;
            end_of_records = end_of_records.max(r.at);
        }
        if names_at < end_of_records || names_at > bytes.len() {
            return Err(TaskError {
                offset: 24,
                kind: OffsetOutOfRange,
            });
        }
        let mut n = Cursor {
            bytes,
            at: names_at,
        };
        for _ in 0..actions {
            let len = n.u16()? as usize;
            let start = n.at;
            n.skip(len)?;
            if bytes
                .get(start..n.at)
                .is_none_or(|s| core::str::from_utf8(s).is_err())
            {
                return Err(n.err(BadName));
            }
        }
        Ok(Self {
            bytes,
            layout: TaskLayout {
                len: bytes.len(),
                facts,
                numerics,
                actions,
                epsilon,
                ticks_per_unit,
                goal_facts,
                goal_conditions,
                init_facts_at,
                init_numerics_at,
                goal_facts_at,
                goal_conditions_at,
                offsets_at,
                names_at,
            },
        })
    }

    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }
    pub fn fact_count(&self) -> usize {
        self.layout.facts
    }
    pub fn numeric_count(&self) -> usize {
        self.layout.numerics
    }
    pub fn action_count(&self) -> usize {
        self.layout.actions
    }
    /// The separation between interfering happenings, in ticks.
    pub fn epsilon(&self) -> u32 {
        self.layout.epsilon
    }
    pub fn ticks_per_unit(&self) -> u32 {
        self.layout.ticks_per_unit
    }
    pub fn initially_true(&self, fact: usize) -> bool {
        self.bytes
            .get(self.layout.init_facts_at + fact / 8)
            .is_some_and(|b| b & (1 << (fact % 8)) != 0)
    }
    pub fn initial_value(&self, var: usize) -> i64 {
        read_i64(self.bytes, self.layout.init_numerics_at + 8 * var)
    }
    pub fn goal_facts(&self) -> Facts<'a> {
        Facts::new(
            self.bytes,
            self.layout.goal_facts_at,
            self.layout.goal_facts,
        )
    }
    pub fn goal_conditions(&self) -> impl Iterator<Item = Linear<'a>> + 'a {
        let bytes = self.bytes;
        let mut at = self.layout.goal_conditions_at;
        (0..self.layout.goal_conditions).map(move |_| {
            let (lin, next) = linear_at(bytes, at, false);
            at = next;
            lin
        })
    }
    /// Action `a` (`a < action_count()`).
    pub fn action(&self, a: usize) -> Action<'a> {
        let at = read_u32(self.bytes, self.layout.offsets_at + 4 * a) as usize;
        read_action(self.bytes, at)
    }
    /// The first `N` fact lists of action `a`'s record, in [`FactList`]'s order (`N` of 2:
    /// its start's conditions and its invariants; 3: and its end's conditions), without
    /// decoding the rest: what the search asks of every step since a fact's last writer when it
    /// orders a write after the fact's readers.
    pub fn leading_facts<const N: usize>(&self, a: usize) -> [Facts<'a>; N] {
        let at = read_u32(self.bytes, self.layout.offsets_at + 4 * a) as usize;
        let mut rest = self
            .bytes
            .get(at..)
            .and_then(|r| r.get(24..))
            .unwrap_or(&[]);
        let mut lists = [Facts { list: &[] }; N];
        for slot in lists.iter_mut() {
            let Some((count, tail)) = rest.split_first_chunk::<2>() else {
                break;
            };
            let n = u16::from_le_bytes(*count) as usize;
            let (list, tail) = tail.split_at_checked(2 * n).unwrap_or((&[], &[]));
            *slot = Facts {
                list: list.as_chunks::<2>().0,
            };
            rest = tail;
        }
        lists
    }
    /// Action `a`'s duration bounds (lb, ub) and its start and end windows, read from its
    /// record's header without decoding its lists (the search's path and STN read these for
    /// every step of every path it loads).
    pub fn action_times(&self, a: usize) -> ((u32, u32), (u32, u32), (u32, u32)) {
        let at = read_u32(self.bytes, self.layout.offsets_at + 4 * a) as usize;
        let head = self
            .bytes
            .get(at..)
            .and_then(|r| r.first_chunk::<24>())
            .unwrap_or(&[0; 24]);
        let (words, _) = head.as_chunks::<4>();
        let word = |k: usize| words.get(k).map_or(0, |&w| u32::from_le_bytes(w));
        ((word(0), word(1)), (word(2), word(3)), (word(4), word(5)))
    }
    /// The bytes of action `a`'s record (`a < action_count()`), for tasks written from this
    /// one (a replan, [`crate::replan`]).
    pub fn action_record(&self, a: usize) -> &'a [u8] {
        let at = read_u32(self.bytes, self.layout.offsets_at + 4 * a) as usize;
        let act = read_action(self.bytes, at);
        let (mut end, n) = act.numeric_list(4);
        for _ in 0..n {
            end = linear_at(self.bytes, end, true).1;
        }
        self.bytes.get(at..end).unwrap_or(&[])
    }
    /// The action's name, as the front end wrote it (`(navigate rover0 waypoint1 waypoint2)`).
    pub fn action_name(&self, a: usize) -> &'a str {
        let mut at = self.layout.names_at;
        for _ in 0..a {
            at += 2 + read_u16(self.bytes, at) as usize;
        }
        let len = read_u16(self.bytes, at) as usize;
        self.bytes
            .get(at + 2..at + 2 + len)
            .and_then(|s| core::str::from_utf8(s).ok())
            .unwrap_or("")
    }
}

fn check_linear(c: &mut Cursor<'_>, numerics: usize, effect: bool) -> Result<(), TaskError> {
    let kind = c.u8()?;
    if effect {
        if kind > EffectOp::Decrease as u8 {
            return Err(c.err(TaskErrorKind::BadEffectOp));
        }
        if c.u16()? as usize >= numerics {
            return Err(c.err(TaskErrorKind::VariableOutOfRange));
        }
    } else if kind > Comparison::Equal as u8 {
        return Err(c.err(TaskErrorKind::BadComparison));
    }
    let terms = c.u8()?;
    c.i64()?;
    for _ in 0..terms {
        if c.u16()? as usize >= numerics {
            return Err(c.err(TaskErrorKind::VariableOutOfRange));
        }
        c.i64()?;
    }
    Ok(())
}

fn check_action(c: &mut Cursor<'_>, facts: usize, numerics: usize) -> Result<(), TaskError> {
    let lb = c.u32()?;
    let ub = c.u32()?;
    if lb > ub {
        return Err(c.err(TaskErrorKind::DurationBoundsReversed));
    }
    for _ in 0..2 {
        let lo = c.u32()?;
        let hi = c.u32()?;
        if lo > hi {
            return Err(c.err(TaskErrorKind::WindowReversed));
        }
    }
    for _ in 0..7 {
        let n = c.u16()?;
        for _ in 0..n {
            if c.u16()? as usize >= facts {
                return Err(c.err(TaskErrorKind::FactOutOfRange));
            }
        }
    }
    for list in 0..5 {
        let n = c.u8()?;
        for _ in 0..n {
            check_linear(c, numerics, list >= 3)?;
        }
    }
    Ok(())
}

/// Read an action record at `at` (validated by [`check_action`]). The search reads records
/// for every successor it tries: the header is taken as one fixed-size array and each list as
/// one slice (a bounds check a list, not one a word or id).
fn read_action(bytes: &[u8], at: usize) -> Action<'_> {
    let record = bytes.get(at..).unwrap_or(&[]);
    let (head, mut rest) = record.split_first_chunk::<24>().unwrap_or((&[0; 24], &[]));
    let (words, _) = head.as_chunks::<4>();
    let word = |k: usize| words.get(k).map_or(0, |&w| u32::from_le_bytes(w));
    let mut lists = [Facts { list: &[] }; 7];
    for slot in lists.iter_mut() {
        let Some((count, tail)) = rest.split_first_chunk::<2>() else {
            break;
        };
        let n = u16::from_le_bytes(*count) as usize;
        let (list, tail) = tail.split_at_checked(2 * n).unwrap_or((&[], &[]));
        *slot = Facts {
            list: list.as_chunks::<2>().0,
        };
        rest = tail;
    }
    Action {
        bytes,
        duration_lb: word(0),
        duration_ub: word(1),
        start_window: (word(2), word(3)),
        end_window: (word(4), word(5)),
        lists,
        numeric_at: bytes.len() - rest.len(),
    }
}

/// One linear expression to write: terms (variable, weight) and a constant, fixed point.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LinearSpec<'s> {
    pub kind: u8,
    pub target: u16,
    pub terms: &'s [(u16, i64)],
    pub constant: i64,
}

/// One action to write.
#[derive(Clone, Debug, Default)]
pub struct ActionSpec<'s> {
    pub name: &'s str,
    pub duration_lb: u32,
    pub duration_ub: u32,
    pub start_window: (u32, u32),
    pub end_window: (u32, u32),
    /// In [`FactList`] order.
    pub facts: [&'s [u16]; 7],
    /// In [`NumericList`] order.
    pub numeric: [&'s [LinearSpec<'s>]; 5],
}

/// Serialise a task into `out` (which it extends through `push`); returns the bytes written.
/// `push` lets a `no_std` caller write into a fixed buffer and the host into a `Vec`.
#[allow(clippy::too_many_arguments)]
pub fn write_task(
    push: &mut dyn FnMut(&[u8]),
    facts: u16,
    numerics: u16,
    epsilon: u32,
    ticks_per_unit: u32,
    initial_facts: &[u16],
    initial_values: &[i64],
    goal_facts: &[u16],
    goal_conditions: &[LinearSpec<'_>],
    actions: &[ActionSpec<'_>],
) -> usize {
    let mut written = 0usize;
    let mut put = |b: &[u8]| {
        written += b.len();
        push(b);
    };
    fn linear_len(l: &LinearSpec<'_>, effect: bool) -> usize {
        1 + if effect { 2 } else { 0 } + 1 + 8 + 10 * l.terms.len()
    }
    fn action_len(a: &ActionSpec<'_>) -> usize {
        24 + a.facts.iter().map(|l| 2 + 2 * l.len()).sum::<usize>()
            + a.numeric
                .iter()
                .enumerate()
                .map(|(i, l)| 1 + l.iter().map(|x| linear_len(x, i >= 3)).sum::<usize>())
                .sum::<usize>()
    }
    let n_actions = actions.len();
    let mut at = HEADER_BYTES
        + (facts as usize).div_ceil(8)
        + 8 * numerics as usize
        + 2 * goal_facts.len()
        + goal_conditions
            .iter()
            .map(|l| linear_len(l, false))
            .sum::<usize>();
    let records_at = at + 4 * n_actions;
    let names_at = records_at + actions.iter().map(action_len).sum::<usize>();
    put(&MAGIC);
    put(&VERSION.to_le_bytes());
    put(&facts.to_le_bytes());
    put(&numerics.to_le_bytes());
    put(&(n_actions as u16).to_le_bytes());
    put(&epsilon.to_le_bytes());
    put(&ticks_per_unit.to_le_bytes());
    put(&(goal_facts.len() as u16).to_le_bytes());
    put(&(goal_conditions.len() as u16).to_le_bytes());
    put(&(names_at as u32).to_le_bytes());
    let mut bits = [0u8; 1];
    for byte in 0..(facts as usize).div_ceil(8) {
        bits[0] = 0;
        for &f in initial_facts {
            if f as usize / 8 == byte {
                bits[0] |= 1 << (f % 8);
            }
        }
        put(&bits);
    }
    for v in 0..numerics as usize {
        put(&initial_values.get(v).copied().unwrap_or(0).to_le_bytes());
    }
    for g in goal_facts {
        put(&g.to_le_bytes());
    }
    let put_linear = |put: &mut dyn FnMut(&[u8]), l: &LinearSpec<'_>, effect: bool| {
        put(&[l.kind]);
        if effect {
            put(&l.target.to_le_bytes());
        }
        put(&[l.terms.len() as u8]);
        put(&l.constant.to_le_bytes());
        for (v, w) in l.terms {
            put(&v.to_le_bytes());
            put(&w.to_le_bytes());
        }
    };
    for g in goal_conditions {
        put_linear(&mut put, g, false);
    }
    at = records_at;
    for a in actions {
        put(&(at as u32).to_le_bytes());
        at += action_len(a);
    }
    for a in actions {
        put(&a.duration_lb.to_le_bytes());
        put(&a.duration_ub.to_le_bytes());
        put(&a.start_window.0.to_le_bytes());
        put(&a.start_window.1.to_le_bytes());
        put(&a.end_window.0.to_le_bytes());
        put(&a.end_window.1.to_le_bytes());
        for list in a.facts {
            put(&(list.len() as u16).to_le_bytes());
            for f in list {
                put(&f.to_le_bytes());
            }
        }
        for (i, list) in a.numeric.iter().enumerate() {
            put(&[list.len() as u8]);
            for l in *list {
                put_linear(&mut put, l, i >= 3);
            }
        }
    }
    for a in actions {
        put(&(a.name.len() as u16).to_le_bytes());
        put(a.name.as_bytes());
    }
    written
}
