# SPDX-License-Identifier: MIT
# Sourced by the benchmark scripts: where the shared benchmark scenes are, and their cameras.
#   scenes                   $SPACEBVH_SCENES, default ../shared/scenes beside the checkout
#   SPACEBVH_SCENE_MANIFEST  exported as $scenes/MANIFEST.md unless already set, so that every `spacebvh`
#                            the script runs takes a scene's primary rays from the camera the collection
#                            lists for it (the CLI reads no file it is not told about)
#   require_scenes [VERB]    exits 0 with a note when $scenes is absent: the scenes are not part of the
#                            repository, and a checkout without them has nothing to measure
# Usage, after `cd` to the repository root:  source bench/lib/scenes.sh; require_scenes
scenes=${SPACEBVH_SCENES:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)/../shared/scenes}
if [ -z "${SPACEBVH_SCENE_MANIFEST:-}" ] && [ -f "$scenes/MANIFEST.md" ]; then
    export SPACEBVH_SCENE_MANIFEST="$scenes/MANIFEST.md"
fi

require_scenes() {
    if [ ! -d "$scenes" ]; then
        echo "no scene folder $scenes (set SPACEBVH_SCENES): nothing to ${1:-benchmark}" >&2
        exit 0
    fi
}
