//! Scenario schema, closed-loop runner and scoring (design §6).
