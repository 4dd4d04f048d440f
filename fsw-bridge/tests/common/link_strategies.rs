//! Proptest strategies for link frames and their parts.
use fsw_bridge::link::{Clcw, Directive, LinkFrame, LinkReport, VirtualChannel, VC_COUNT};
use proptest::prelude::*;

use super::u32s;

pub fn vcs() -> impl Strategy<Value = VirtualChannel> {
    prop_oneof![
        Just(VirtualChannel::Mission),
        Just(VirtualChannel::Instrument)
    ]
}

pub fn clcws() -> impl Strategy<Value = Clcw> {
    (
        any::<u8>(),
        any::<bool>(),
        any::<bool>(),
        any::<bool>(),
        0u8..4,
    )
        .prop_map(
            |(report_value, lockout, wait, retransmit, farm_b_counter)| Clcw {
                report_value,
                lockout,
                wait,
                retransmit,
                farm_b_counter,
            },
        )
}

pub fn reports() -> impl Strategy<Value = LinkReport> {
    (
        u32s(),
        [clcws(), clcws()],
        any::<[u8; VC_COUNT]>(),
        any::<[bool; VC_COUNT]>(),
        any::<bool>(),
    )
        .prop_map(|(round, clcw, sent_vs, backlog, lost)| LinkReport {
            round,
            clcw,
            sent_vs,
            backlog,
            lost,
        })
}

pub fn directives() -> impl Strategy<Value = Directive> {
    prop_oneof![
        vcs().prop_map(|vc| Directive::Unlock { vc }),
        (vcs(), any::<u8>()).prop_map(|(vc, vr)| Directive::SetVr { vc, vr }),
    ]
}

pub fn link_frames<M, S>(msgs: fn() -> S) -> impl Strategy<Value = LinkFrame<M>>
where
    M: Clone + core::fmt::Debug + 'static,
    S: Strategy<Value = M> + 'static,
{
    // Boxed: the message strategies are deep, and unboxed they overflow a test thread's stack
    // in debug builds.
    prop_oneof![
        (vcs(), any::<u8>(), msgs().boxed())
            .prop_map(|(vc, ns, msg)| LinkFrame::Ad { vc, ns, msg })
            .boxed(),
        msgs().boxed().prop_map(LinkFrame::Bd).boxed(),
        (u32s(), directives()).prop_map(|(round, directive)| LinkFrame::Bc { round, directive }),
        reports().prop_map(LinkFrame::Report),
        u32s().prop_map(|round| LinkFrame::RoundEnd { round }),
    ]
}
