#!/usr/bin/env bash
# Are two builds' answers the same, byte for byte? For refactors that must not change
# what is found: rows, events, sources and JSON documents (the metadata's `parameters`
# and `tool` left out), at nine flag sets, on the example and on every scene folder
# given (each holding rec.wav and array.toml, as benches/check.py --work writes them).
#   benches/same_answers.sh OLD_SSL NEW_SSL [SCENE_DIR ...]
set -uo pipefail
old=$1; new=$2; shift 2
cd "$(dirname "$0")/.."
cases=("testdata/example.wav testdata/prism.toml")
for dir in "$@"; do cases+=("$dir/rec.wav $dir/array.toml"); done
flags=("" "--paper" "--no-track" "--events" "--min-score 0.3" "-t 1.5 --sources"
    "--frame-ms 30 --band 300-3400" "--paper --interpolation cosine" "-f json")
n=0; d=0
for c in "${cases[@]}"; do
    set -- $c
    for f in "${flags[@]}"; do
        if [[ $f == *json* ]]; then
            a=$($old analyze "$1" -g "$2" $f -q | jq -c 'del(.parameters, .tool)')
            b=$($new analyze "$1" -g "$2" $f -q | jq -c 'del(.parameters, .tool)')
        else
            a=$($old analyze "$1" -g "$2" $f -q 2>&1)
            b=$($new analyze "$1" -g "$2" $f -q 2>&1)
        fi
        n=$((n + 1))
        [ "$a" == "$b" ] || { d=$((d + 1)); echo "differ: $1 $f"; }
    done
done
echo "compared $n, differ $d"
[ "$d" -eq 0 ]
