//! External functions as modules (seed 001, section 4.5): a domain declares
//! `(:modules (:module NAME (:function (f ?a - type ...)) ...))`, and the host registers a
//! Rust implementation of each module by name. The front end evaluates every function on every
//! parameter choice while it compiles the task (as Stellar does), so the planner sees only
//! numbers. [`PathEstimate`] is the first module: traversal times between rover waypoints.
use std::collections::BTreeMap;

/// One external module: named functions of object names to numbers.
pub trait ExternalModule {
    /// The module's name as the domain's `(:module NAME ...)` gives it (lowercase).
    fn name(&self) -> &str;
    /// `function` on `args` (object names, lowercase), or why it has no value there.
    fn evaluate(&self, function: &str, args: &[&str]) -> Result<f64, String>;
}

/// The modules a compilation may use, by name.
#[derive(Default)]
pub struct ModuleRegistry {
    modules: BTreeMap<String, Box<dyn ExternalModule>>,
}

impl ModuleRegistry {
    pub fn new() -> Self {
        Self::default()
    }
    pub fn register(&mut self, module: Box<dyn ExternalModule>) {
        self.modules
            .insert(module.name().to_ascii_lowercase(), module);
    }
    pub fn get(&self, name: &str) -> Option<&dyn ExternalModule> {
        self.modules.get(name).map(|m| m.as_ref())
    }
    pub fn names(&self) -> Vec<&str> {
        self.modules.keys().map(String::as_str).collect()
    }
}

/// A path-planning reactor's estimate of traversal times: straight-line distance between
/// waypoint positions (metres) over a speed (metres per time unit), times a terrain factor,
/// plus a fixed turn-in-place time. Functions: `(FUNCTION ?from ?to - waypoint)` gives the
/// estimated time from `?from` to `?to` (0 from a waypoint to itself).
#[derive(Clone, Debug)]
pub struct PathEstimate {
    pub module: String,
    pub function: String,
    pub positions: BTreeMap<String, (f64, f64)>,
    pub speed: f64,
    pub terrain_factor: f64,
    pub turn_time: f64,
}

impl PathEstimate {
    /// A module `module` with one function `function`, the waypoints at `positions`.
    pub fn new(module: &str, function: &str, positions: &[(&str, f64, f64)], speed: f64) -> Self {
        Self {
            module: module.to_ascii_lowercase(),
            function: function.to_ascii_lowercase(),
            positions: positions
                .iter()
                .map(|(n, x, y)| (n.to_ascii_lowercase(), (*x, *y)))
                .collect(),
            speed,
            terrain_factor: 1.0,
            turn_time: 0.0,
        }
    }
}

impl ExternalModule for PathEstimate {
    fn name(&self) -> &str {
        &self.module
    }
    fn evaluate(&self, function: &str, args: &[&str]) -> Result<f64, String> {
        if function != self.function {
            return Err(format!(
                "this module has no function `{function}` (it has `{}`)",
                self.function
            ));
        }
        let [from, to] = args else {
            return Err(format!(
                "`{function}` takes two waypoints, given {}",
                args.len()
            ));
        };
        let pos = |w: &str| {
            self.positions
                .get(w)
                .copied()
                .ok_or_else(|| format!("no position for waypoint `{w}`"))
        };
        let (a, b) = (pos(from)?, pos(to)?);
        if from == to {
            return Ok(0.0);
        }
        if self.speed <= 0.0 {
            return Err("the speed must be positive".into());
        }
        let distance = ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt();
        Ok(distance / self.speed * self.terrain_factor + self.turn_time)
    }
}
