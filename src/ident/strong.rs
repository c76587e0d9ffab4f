//! Strong form: the paper's procedure (3.8)–(3.15) on a density grid (in progress).
