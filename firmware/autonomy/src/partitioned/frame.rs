//! One major frame of both partitions, with the points a test can reset at.
use super::*;

/// What one frame of the two partitions did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Frame {
    /// When the host must grant next (if no input arrives first): see
    /// [`ExecutivePartition::next_wakeup`].
    pub next_wakeup: Option<MissionTimeUs>,
    /// The planner's window.
    pub planner: PlannerStatus,
}

/// Which partition a checkpoint belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    Executive,
    Planner,
}

/// The points of a frame at which [`FrameEnv::proceed`] is asked whether to go on (a test
/// resets there): after each window's work, after each checkpoint, after each transmission.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Point {
    ExecutiveFirstWindow,
    ExecutiveFirstCheckpoint,
    ExecutiveFirstSent,
    PlannerWindow,
    PlannerCheckpoint,
    PlannerSent,
    ExecutiveSecondWindow,
    ExecutiveSecondCheckpoint,
    ExecutiveSecondSent,
}

impl Point {
    pub const ALL: [Point; 9] = [
        Point::ExecutiveFirstWindow,
        Point::ExecutiveFirstCheckpoint,
        Point::ExecutiveFirstSent,
        Point::PlannerWindow,
        Point::PlannerCheckpoint,
        Point::PlannerSent,
        Point::ExecutiveSecondWindow,
        Point::ExecutiveSecondCheckpoint,
        Point::ExecutiveSecondSent,
    ];
}

/// Where a frame's checkpoints go, and whether it goes on at each [`Point`].
pub trait FrameEnv {
    /// Write `side`'s checkpoint (`executive` or `planner`, whichever `side` names: its
    /// `encode_state`). False: the write did not complete (a reset tore it); the frame stops
    /// there. True: [`run_frame`] marks the side checkpointed.
    fn checkpoint(
        &mut self,
        side: Side,
        executive: &ExecutivePartition,
        planner: &PlannerPartition,
    ) -> bool;
    /// Whether the frame goes on after `point` (false: a reset came).
    fn proceed(&mut self, point: Point) -> bool {
        let _ = point;
        true
    }
}

/// The frame stopped at a reset, after this point (or in the checkpoint after it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Interrupted(pub Point);

/// Runs frame `frame` of both partitions at `now` with `planner_budget` validity checks for
/// the planner's window, handing the ports' messages over as the kernel does (what a window
/// sends is in the port at the start of the other side's next window; a port never refuses
/// here: the outboxes are the bound). The decisions go to `out` in the order the windows run
/// (the planner's at the start of the executive's second window). Each window ends with its
/// side's checkpoint, then its transmission.
pub fn run_frame(
    executive: &mut ExecutivePartition,
    planner: &mut PlannerPartition,
    frame: u32,
    now: MissionTimeUs,
    planner_budget: u32,
    out: &mut impl Outputs,
    env: &mut impl FrameEnv,
) -> Result<Frame, Interrupted> {
    let go = |env: &mut dyn FnMut(Point) -> bool, point| {
        if env(point) {
            Ok(())
        } else {
            Err(Interrupted(point))
        }
    };
    executive.first_window(frame, now, out);
    go(&mut |p| env.proceed(p), Point::ExecutiveFirstWindow)?;
    if !env.checkpoint(Side::Executive, executive, planner) {
        return Err(Interrupted(Point::ExecutiveFirstWindow));
    }
    executive.checkpointed();
    go(&mut |p| env.proceed(p), Point::ExecutiveFirstCheckpoint)?;
    executive.transmit(&mut |w| {
        planner.receive(w);
        true
    });
    go(&mut |p| env.proceed(p), Point::ExecutiveFirstSent)?;
    let status = planner.window(planner_budget).unwrap_or_default();
    go(&mut |p| env.proceed(p), Point::PlannerWindow)?;
    if !env.checkpoint(Side::Planner, executive, planner) {
        return Err(Interrupted(Point::PlannerWindow));
    }
    planner.checkpointed();
    go(&mut |p| env.proceed(p), Point::PlannerCheckpoint)?;
    planner.transmit(&mut |w| {
        executive.receive(w);
        true
    });
    go(&mut |p| env.proceed(p), Point::PlannerSent)?;
    executive.second_window(out);
    go(&mut |p| env.proceed(p), Point::ExecutiveSecondWindow)?;
    if !env.checkpoint(Side::Executive, executive, planner) {
        return Err(Interrupted(Point::ExecutiveSecondWindow));
    }
    executive.checkpointed();
    go(&mut |p| env.proceed(p), Point::ExecutiveSecondCheckpoint)?;
    executive.transmit(&mut |w| {
        planner.receive(w);
        true
    });
    go(&mut |p| env.proceed(p), Point::ExecutiveSecondSent)?;
    Ok(Frame {
        next_wakeup: executive.next_wakeup(),
        planner: status,
    })
}
