//! Stage 4, the manoeuvre choice (module docs, "Escape side"): the image side the escape
//! controller dodges away from.

use super::Decision;

impl Decision {
    /// The image side (x in [−1, 1], −1 left) to escape from: for a percept that localises the
    /// object (`localised`: an image extent — the ideal rows, or a detector's image region), the
    /// side on which the course gate predicts it to arrive ([`Decision::pass_side`]) when it
    /// predicts one, else `seen_side`, where the object is seen now (a μ from a temporal-contrast
    /// centroid is too noisy to choose a side).
    pub fn escape_side(&self, seen_side: Option<f32>, localised: bool) -> Option<f32> {
        if localised {
            self.pass_side.or(seen_side)
        } else {
            seen_side
        }
    }
}
