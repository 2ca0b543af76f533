#!/usr/bin/env bash
# The robot demo (the README's second demo command): scripts/demo.sh --robot, which says what it
# does. --raw: the whole answer.
exec "$(dirname "$0")/demo.sh" --robot "$@"
