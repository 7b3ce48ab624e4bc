/* LM-cut (Helmert & Domshlak 2009) of a compiled relaxed task, one state after another.
 *
 * The same task and the same values as planning/lmcut.py's numpy version (ties in the
 * precondition-choice function go to the first costliest precondition, as there), built on
 * demand with the system C compiler and loaded through ctypes. Per round: h_max by a
 * generalized Dijkstra (an achiever fires when its last precondition is settled), the
 * precondition-choice function, the goal zone backwards through zero-cost achievers, the
 * literals reached from the state without entering the zone, and the cut, whose cheapest
 * operator cost is added to h and taken off every operator of the cut.
 *
 * With a `cuts` buffer it also records every cut (the landmarks, for operator counting):
 * state, operator count, then the operators; -2 when the buffer is too small.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define INF 0x1fffffff               /* planning.heuristics.INF */
#define INF64 (INT64_MAX / 4)        /* planning.heuristics.INF_64 */

typedef struct { int32_t v, c; } item;

typedef struct { item *items; int64_t n, cap; } heap_t;

static int push(heap_t *hp, int32_t v, int32_t c) {
    int64_t i;
    if (hp->n == hp->cap) {                      /* values may drop more than once: grow */
        item *more = realloc(hp->items, 2 * hp->cap * sizeof(item));
        if (!more) return -1;
        hp->items = more;
        hp->cap *= 2;
    }
    i = hp->n++;
    while (i > 0) {
        int64_t p = (i - 1) / 2;
        if (hp->items[p].v <= v) break;
        hp->items[i] = hp->items[p];
        i = p;
    }
    hp->items[i].v = v;
    hp->items[i].c = c;
    return 0;
}

static item pop(heap_t *hp) {
    item *heap = hp->items;
    item top = heap[0], last = heap[--hp->n];
    int64_t i = 0, n = hp->n;
    for (;;) {
        int64_t l = 2 * i + 1, r = l + 1, m;
        if (l >= n) break;
        m = (r < n && heap[r].v < heap[l].v) ? r : l;
        if (heap[m].v >= last.v) break;
        heap[i] = heap[m];
        i = m;
    }
    heap[i] = last;
    return top;
}

/* Returns 0, -1 if memory ran out, -2 if `cuts` (cut_cap values) is too small.
   holds: N rows of C bytes; out: N values; *cut_len: values written to cuts. */
int lmcut_batch(int64_t N, int64_t C, int64_t A, int64_t O, int64_t W, const int64_t *pre,
                const int64_t *pre_of_start, const int64_t *pre_of, const int32_t *n_pre,
                const int64_t *eff, const int64_t *owner, const int64_t *eff_start,
                const int32_t *op_cost0, const int64_t *op_start, const int64_t *op_ach,
                int64_t goal_col, const uint8_t *holds, int64_t *out,
                int64_t *cuts, int64_t cut_cap, int64_t *cut_len) {
    int32_t *hm = malloc(C * sizeof(int32_t)), *unsat = malloc(A * sizeof(int32_t)),
            *pcf = malloc(A * sizeof(int32_t)), *cost = malloc(O * sizeof(int32_t)),
            *stack = malloc(C * sizeof(int32_t)), *cutops = malloc(O * sizeof(int32_t));
    uint8_t *done = malloc(C), *zone = malloc(C), *reach = malloc(C), *cutmark = calloc(O, 1);
    heap_t hp = {malloc((C + A + 1) * sizeof(item)), 0, C + A + 1};
    int status = 0;
    if (cut_len) *cut_len = 0;
    if (!hm || !unsat || !pcf || !cost || !stack || !cutops || !done || !zone || !reach || !cutmark || !hp.items) {
        status = -1;
        goto end;
    }
    for (int64_t s = 0; s < N; s++) {
        const uint8_t *hs = holds + s * C;
        int64_t h = 0;
        memcpy(cost, op_cost0, O * sizeof(int32_t));
        hp.n = 0;
        for (int64_t c = 0; c < C; c++) {
            done[c] = 0;
            hm[c] = INF;
            if (hs[c]) {
                hm[c] = 0;
                if (push(&hp, 0, (int32_t)c)) { status = -1; goto end; }
            }
        }
        for (int64_t a = 0; a < A; a++) {
            unsat[a] = n_pre[a];
            pcf[a] = -1;
        }
        while (hp.n) {                                         /* h_max, first round */
            item it = pop(&hp);
            int32_t c = it.c;
            if (done[c]) continue;
            done[c] = 1;
            for (int64_t k = pre_of_start[c]; k < pre_of_start[c + 1]; k++) {
                int64_t a = pre_of[k];
                if (--unsat[a] == 0) {
                    int32_t nv = it.v + cost[owner[a]];
                    int64_t e = eff[a];
                    if (nv < hm[e]) {
                        hm[e] = nv;
                        if (push(&hp, nv, (int32_t)e)) { status = -1; goto end; }
                    }
                }
            }
        }
        for (;;) {
            int64_t sp = 0, ncut = 0;
            int32_t m = INF;
            if (hm[goal_col] >= INF) { h = INF64; break; }
            if (hm[goal_col] == 0) break;
            for (int64_t a = 0; a < A; a++) {                /* precondition-choice function */
                const int64_t *p = pre + a * W;
                int64_t best = p[0];
                if (unsat[a] != 0) continue;
                for (int64_t j = 1; j < W && p[j] != C - 1; j++)   /* C - 1 (TRUE) pads the row */
                    if (hm[p[j]] > hm[best]) best = p[j];
                pcf[a] = (int32_t)best;
            }
            memset(zone, 0, C);                              /* the goal zone */
            zone[goal_col] = 1;
            stack[sp++] = (int32_t)goal_col;
            while (sp) {
                int32_t c = stack[--sp];
                for (int64_t a = eff_start[c]; a < eff_start[c + 1]; a++) {
                    int32_t p = pcf[a];
                    if (p >= 0 && cost[owner[a]] == 0 && !zone[p]) {
                        zone[p] = 1;
                        stack[sp++] = p;
                    }
                }
            }
            memset(reach, 0, C);                             /* reached before the zone; the cut */
            for (int64_t c = 0; c < C; c++)
                if (hs[c]) { reach[c] = 1; stack[sp++] = (int32_t)c; }
            while (sp) {
                int32_t c = stack[--sp];
                for (int64_t k = pre_of_start[c]; k < pre_of_start[c + 1]; k++) {
                    int64_t a = pre_of[k], e = eff[a];
                    if (pcf[a] != c) continue;
                    if (zone[e]) {
                        int64_t o = owner[a];
                        if (!cutmark[o]) {
                            cutmark[o] = 1;
                            cutops[ncut++] = (int32_t)o;
                            if (cost[o] < m) m = cost[o];
                        }
                    } else if (!reach[e]) {
                        reach[e] = 1;
                        stack[sp++] = (int32_t)e;
                    }
                }
            }
            if (cuts && ncut > 0) {
                if (*cut_len + 2 + ncut > cut_cap) { status = -2; goto end; }
                cuts[(*cut_len)++] = s;
                cuts[(*cut_len)++] = ncut;
                for (int64_t i = 0; i < ncut; i++) cuts[(*cut_len)++] = cutops[i];
            }
            for (int64_t i = 0; i < ncut; i++) {
                cost[cutops[i]] -= m;
                cutmark[cutops[i]] = 0;
            }
            if (ncut == 0 || m <= 0) break;                  /* cannot happen; h so far is a bound */
            h += m;
            /* h_max again, incrementally: costs only dropped, so only values below can change.
               Seed with the cut's achievers, then follow the achievers whose costliest
               precondition dropped; the others keep their maximum. */
            hp.n = 0;
            for (int64_t i = 0; i < ncut; i++) {
                int64_t o = cutops[i];
                for (int64_t k = op_start[o]; k < op_start[o + 1]; k++) {
                    int64_t a = op_ach[k], e = eff[a];
                    if (pcf[a] < 0) continue;
                    int32_t nv = hm[pcf[a]] + cost[o];
                    if (nv < hm[e]) {
                        hm[e] = nv;
                        if (push(&hp, nv, (int32_t)e)) { status = -1; goto end; }
                    }
                }
            }
            while (hp.n) {
                item it = pop(&hp);
                int32_t c = it.c;
                if (it.v > hm[c]) continue;                  /* stale */
                for (int64_t k = pre_of_start[c]; k < pre_of_start[c + 1]; k++) {
                    int64_t a = pre_of[k], e = eff[a];
                    const int64_t *p = pre + a * W;
                    int64_t best = p[0];
                    int32_t nv;
                    if (pcf[a] != c) continue;
                    for (int64_t j = 1; j < W && p[j] != C - 1; j++)
                        if (hm[p[j]] > hm[best]) best = p[j];
                    pcf[a] = (int32_t)best;
                    nv = hm[best] + cost[owner[a]];
                    if (nv < hm[e]) {
                        hm[e] = nv;
                        if (push(&hp, nv, (int32_t)e)) { status = -1; goto end; }
                    }
                }
            }
        }
        out[s] = h;
    }
end:
    free(hm); free(unsat); free(pcf); free(cost); free(stack); free(cutops);
    free(done); free(zone); free(reach); free(cutmark); free(hp.items);
    return status;
}
