"""The specialiser: the engine's recursions traced on symbols for one model structure (:mod:`.trace`), emitted as
straight-line SIMD code over blocks of configurations and kept on disk (:mod:`.build`), driven block by block
(:mod:`.lanes`)."""
