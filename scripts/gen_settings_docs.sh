#!/usr/bin/env bash
# Regenerates docs/settings.md and the README's settings table (between
# <!-- settings:begin --> and <!-- settings:end -->) from `hrad settings`,
# which runs every component's reader: the docs cannot disagree with the code.
#   scripts/gen_settings_docs.sh [HRAD]          rewrite both files
#   scripts/gen_settings_docs.sh --check [HRAD]  exit 1 when either differs
# HRAD defaults to build/apps/hrad.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
check=0
if [[ "${1:-}" == "--check" ]]; then check=1; shift; fi
hrad="${1:-$root/build/apps/hrad}"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

"$hrad" settings --markdown > "$tmp/settings.md"
"$hrad" settings --readme > "$tmp/table.md"
# The README with its block replaced by the generated table.
awk -v table="$tmp/table.md" '
    /^<!-- settings:begin -->$/ { print; while ((getline line < table) > 0) print line; skip = 1; next }
    /^<!-- settings:end -->$/ { skip = 0 }
    !skip { print }' "$root/README.md" > "$tmp/README.md"
grep -q '^<!-- settings:begin -->$' "$root/README.md" || { echo "README.md has no <!-- settings:begin --> line" >&2; exit 1; }

if (( check )); then
    status=0
    for f in docs/settings.md README.md; do
        new="$tmp/$(basename "$f")"
        if ! diff -u "$root/$f" "$new" > "$tmp/diff" 2>&1; then
            echo "$f differs from what hrad settings generates:" >&2
            head -40 "$tmp/diff" >&2
            status=1
        fi
    done
    if (( status )); then
        echo "regenerate with: scripts/gen_settings_docs.sh $hrad" >&2
    fi
    exit $status
fi
mkdir -p "$root/docs"
cp "$tmp/settings.md" "$root/docs/settings.md"
cp "$tmp/README.md" "$root/README.md"
echo "wrote docs/settings.md and README.md's settings block"
