"""Durable streaming: what lets a falsification run over data larger than
memory and survive interruptions.

``npy`` reads ``.npy`` files in chunks, ``chunks`` turns arrays, files and
iterables into chunk sources, ``checkpoint`` saves and resumes a run's
progress in a folder guarded by ``folder_lock`` (its ``state`` file and
checksummed ``parts``; ``identity`` fingerprints the model a run used),
``atomic`` writes files whole or not at all, and ``progress`` draws the bar. Nothing here knows the method:
the engine feeds it chunks and accumulators.
"""
