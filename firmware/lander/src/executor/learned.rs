//! What an executor has learned by measurement, carried across a rebuild (a model uplink
//! builds a new executor from the state: without this the new one would plan with the model's
//! priors again): the measured durations and energies of IV.C.3 ([`ParameterUpdate`]), the
//! measured product volumes ([`VolumeFactors`]) and the radio energy the current sol's
//! downlinks have spent. [`Executor::learned`] reads it, [`Executor::set_learned`] gives it to
//! a new executor (natively after [`Executor::new`], on the target after
//! [`Executor::reset`], from the setup's learned part: both decide the same).
//!
//! The ground may also set a parameter itself ([`Learned::set_parameter`]): a task's duration
//! and energy prior for a site, through the same path (a model uplink carrying it).
use heapless::Vec;

use super::*;

/// The learned state an executor is built with.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Learned {
    /// Measured (or ground-set) duration and energy per (kind, site), replacing the priors.
    pub params: Vec<ParameterUpdate, MAX_PARAMETER_UPDATES>,
    /// Measured product volumes against the model's.
    pub volumes: VolumeFactors,
    /// (sol, mJ): radio energy the dispatched downlinks of that sol planned to spend.
    pub comm_spent: (u16, u64),
}

impl Learned {
    /// Sets the parameter of `update.kind` at `update.site` (replacing one in force); false
    /// when [`MAX_PARAMETER_UPDATES`] are held already and this one is new.
    pub fn set_parameter(&mut self, update: ParameterUpdate) -> bool {
        match self
            .params
            .iter_mut()
            .find(|p| p.kind == update.kind && p.site == update.site)
        {
            Some(p) => {
                *p = update;
                true
            }
            None => self.params.push(update).is_ok(),
        }
    }
}

impl<const NODES: usize, const QUEUE: usize> Executor<NODES, QUEUE> {
    /// What this executor has learned (to build the next one with).
    pub fn learned(&self) -> Learned {
        Learned {
            params: self.params.clone(),
            volumes: self.volumes.clone(),
            comm_spent: self.comm_spent,
        }
    }

    /// Takes `learned` as its own: meant right after the executor is built (before its first
    /// step). The parameters apply from the next plan: a search under way (the first plan)
    /// starts again with them, so the executor plans as if it had measured them itself. Equal
    /// to what it holds already, nothing changes (no restart).
    pub fn set_learned(&mut self, learned: &Learned) {
        if self.params == learned.params
            && self.volumes == learned.volumes
            && self.comm_spent == learned.comm_spent
        {
            return;
        }
        self.params.clear();
        for p in learned.params.iter() {
            // Never fails: the same capacity.
            let _ = self.params.push(*p);
        }
        self.volumes = learned.volumes.clone();
        self.comm_spent = learned.comm_spent;
        if let Mode::Planning { reason } = self.mode {
            self.restart_planning(reason);
        }
    }
}
