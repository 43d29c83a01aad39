//! Controllers: the escape controller and RL action adapters (design §1).
