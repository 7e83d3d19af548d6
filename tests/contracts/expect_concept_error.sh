#!/bin/sh
# Usage: expect_concept_error.sh CONCEPT MEMBER COMPILER ARGS...
# Passes when the compile fails and its diagnostics name both the concept and the missing member.
concept=$1; member=$2; shift 2
out=$("$@" 2>&1) && { echo "compiled, but the law lacks $member: the concept did not reject it"; exit 1; }
echo "$out" | grep -q "$concept" || { echo "the error does not name the concept $concept:"; echo "$out" | head -20; exit 1; }
echo "$out" | grep -q "$member" || { echo "the error does not name the missing member $member:"; echo "$out" | head -20; exit 1; }
echo "rejected, naming $concept and $member"
