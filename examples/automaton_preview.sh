#!/usr/bin/env bash
# Renders the automaton cumulus sequence (examples/scenes/automaton_cumulus.toml, 96 frames) and
# makes a PNG contact sheet of every 8th frame, out/automaton_cumulus_contact.png (GIF=1: also
# out/automaton_cumulus.gif; RENDER=0: reuse the frames in out/). Extra arguments go to
# `nimbus render` (e.g. --frames 1-24); without them all 96 frames are rendered (the automaton
# simulates every step anyway). See examples/preview.sh.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ $# -eq 0 ]; then set -- --frames 1-96; fi
exec bash "$root/examples/preview.sh" "$root/examples/scenes/automaton_cumulus.toml" "$@"
