//! The event camera's events (`[world.camera] kind = "events"`, `loomlab run --sensor events`) as
//! the detectors receive them: the simulator's packet converted to [`EventInput`].

use loomlab_detector::{Event, EventInput};
use loomlab_sim::EventPacket;

/// The detectors' view of `packet`, its events converted into `buf` (reused from frame to frame).
pub(super) fn event_input<'a>(packet: &'a EventPacket, buf: &'a mut Vec<Event>) -> EventInput<'a> {
    buf.clear();
    buf.extend(packet.events.iter().map(|e| Event {
        t_s: e.t_s,
        x: e.x,
        y: e.y,
        polarity: e.polarity,
    }));
    EventInput {
        n: packet.n as usize,
        t_start_s: packet.t_start_s,
        t_end_s: packet.t_end_s,
        events: buf,
        on_counts: &packet.on_counts,
        off_counts: &packet.off_counts,
    }
}
