//! [`Executor::reset`]: an executor built in place, for the planner partition, whose stack
//! cannot hold the executor (about 156 KB at the default capacities) that
//! [`Executor::new`] returns by value.
use super::*;

impl<const NODES: usize, const QUEUE: usize> Executor<NODES, QUEUE> {
    /// Makes `self` the executor [`Executor::new`] builds without a plan (its first steps make
    /// the plan with the search) for `primitives` (the model's), `network`, `timeline` and
    /// `context`, then given `learned` ([`Executor::set_learned`]), writing every field in
    /// place: no temporary larger than the placement's timeline is made, and the first plan is
    /// set up once, with `learned` (on the target the whole build runs inside one planner
    /// window). Whatever `self` held before is gone.
    pub fn reset(
        &mut self,
        config: ExecConfig,
        primitives: &Vec<PrimitiveSpec, MAX_PRIMITIVES>,
        network: &FlatNetwork,
        timeline: &TimelinePlacement,
        context: &ScienceContext,
        learned: &Learned,
    ) {
        self.config = config;
        self.primitives.clear();
        for p in primitives.iter() {
            // Never fails: the same capacity.
            let _ = self.primitives.push(p.clone());
        }
        self.network.chains.clear();
        for c in network.chains.iter() {
            // Never fails: the same capacity.
            let _ = self.network.chains.push(c.clone());
        }
        self.science = chain_science(primitives, network);
        self.context = context.clone();
        self.assessor = Assessor::default();
        self.timeline = timeline.clone();
        self.index_cache.clear();
        self.params.clear();
        for p in learned.params.iter() {
            // Never fails: the same capacity.
            let _ = self.params.push(*p);
        }
        self.steps.clear();
        self.cursor = 0;
        self.mode = Mode::Ready;
        self.executed.clear();
        self.closed_tasks.clear();
        self.replan_pending = None;
        self.search.reconfigure(SearchConfig::exhaustive(0));
        self.planning_from = (timeline.horizon_start, timeline.battery_mj);
        self.plans = 0;
        self.log.clear();
        self.stats = ExecStats::default();
        self.last_search = SearchStats::default();
        self.last_plan_value = (RankedUtility::ZERO, 0);
        self.initial_battery_mj = timeline.battery_mj;
        self.now = timeline.horizon_start;
        self.battery_mj = timeline.battery_mj;
        // elap-downlink's link and data state, as `new` leaves it (no link modelled, nothing
        // onboard): `set_comms` and `set_onboard_data` give them after the reset; the volume
        // factors and the sol's radio energy spent are learned.
        self.comms = None;
        self.onboard.clear();
        self.volumes = learned.volumes.clone();
        self.downlink_sizes.clear();
        self.payload.clear();
        self.comm_spent = learned.comm_spent;
        self.data_stats = DataStats::default();
        // `self.sizing` is set up afresh by each downlink's dispatch (`begin_sizing`).
        self.begin_planning(Reason::Initial);
    }
}
