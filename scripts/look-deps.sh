#!/usr/bin/env bash
# Install what `kami bench look` needs beside Kami (docs/look.md): Mitsuba 3 (the path
# tracer; its scalar_rgb variant runs on any CPU), NVIDIA's FLIP and numpy, from PyPI.
# `cargo test` needs none of them. Pass another interpreter as $PYTHON (then give the bench
# `--python` too).
set -euo pipefail
PYTHON=${PYTHON:-python3}
"$PYTHON" -m pip install mitsuba flip-evaluator numpy
"$PYTHON" -c "import mitsuba, flip_evaluator, numpy; print('mitsuba', mitsuba.__version__, 'ready')"
