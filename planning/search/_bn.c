/* The Bellman-Novelty search loop (planning/search/bellman_novelty.py) in C.
 *
 * The same algorithm, turn for turn, as the Python implementation: the same
 * successor order as Model.successors, the same (state, depth) dedup, the same
 * tick counters, heaps ordered on the same keys, the same novelty tables and
 * width cache, and the same value batches (flush: the pending nodes' states
 * not yet valued, plus up to `prefetch` states of their children). A value is
 * either
 *   - native: a C function called at each flush (`bn_native_fn`), or
 *   - Python: bn_run returns BN_NEED with the states to value in `need`; the
 *     caller writes their q_max into `need_q` and calls bn_run again.
 * Floating point: no contraction (built with -ffp-contract=off), so G and the
 * Bellman keys are the same doubles as Python's.
 *
 * States are W little-endian 64-bit words (bit i of the int state is bit i % 64
 * of word i / 64). Nothing here allocates per expansion except amortised array
 * growth; everything is freed by bn_free.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define BN_DONE 0
#define BN_NEED 1
#define BN_ENOMEM -1
#define BN_EVALUE -2                   /* the compiled value refused its input (another model or task) */

typedef int (*bn_native_fn)(void *ctx, int64_t task, const uint64_t *states, int64_t n, int64_t W, double *out);

/* ---- the model ------------------------------------------------------------------------------------ */
typedef struct {
    int64_t W, n_atoms, n_actions;
    int64_t n_entries;          /* variants in candidate order: the always group, then per trigger atom */
    const uint64_t *e_pos, *e_neg, *e_add, *e_del;  /* n_entries * W */
    const int32_t *e_action;
    const int64_t *e_cost;
    const uint8_t *e_multi;
    const int32_t *e_cond0, *e_condn;               /* the variant's conditional effects */
    const uint64_t *c_pos, *c_neg, *c_add, *c_del;  /* n_conds * W */
    int64_t n_always;                               /* entries [0, n_always) */
    const int32_t *trig0;                           /* (n_atoms + 1): trigger atom i's entries [trig0[i], trig0[i+1]) */
    int64_t n_goals;                                /* the task's goal: any of (pos, neg) */
    const uint64_t *g_pos, *g_neg;
} bn_model;

/* ---- growable arrays ------------------------------------------------------------------------------ */
static int grow(void **p, int64_t *cap, int64_t need, size_t elem) {
    if (need <= *cap) return 0;
    int64_t c = *cap ? *cap : 256;
    while (c < need) c *= 2;
    void *q = realloc(*p, (size_t)c * elem);
    if (!q) return -1;
    *p = q;
    *cap = c;
    return 0;
}
#define GROW(arr, cap, need) grow((void **)&(arr), &(cap), (need), sizeof(*(arr)))

static inline uint64_t mix64(uint64_t x) {
    x ^= x >> 30; x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27; x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return x;
}

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* The stats' section times are taken in ticks: the time-stamp counter where there is one (a few cycles to
 * read, where clock_gettime costs as much as a width test), converted to seconds at the end with the ratio
 * of seconds to ticks over the whole search. */
#if defined(__x86_64__) || defined(__i386__)
#include <x86intrin.h>
static inline uint64_t ticks(void) { return __rdtsc(); }
#else
static inline uint64_t ticks(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (uint64_t)t.tv_sec * 1000000000ULL + (uint64_t)t.tv_nsec;
}
#endif

/* ---- heaps ---------------------------------------------------------------------------------------- */
/* 4-ary min-heaps (the pop order is the order of the keys alone, unique by their ticks, whatever the
 * heap's shape). H_B: (key, tick), key = -(G + gamma^d q). H_N: one integer (w, d, tick) packed so
 * that it orders as Python's tuple. Each item carries its node. Ticks count pushes: under 2^32. */
typedef struct { double key; uint32_t tick; int32_t nid; } hb_item;
typedef struct { uint64_t key; int32_t nid; int32_t pad; } hn_item;
#define HN_KEY(w, d, tick) (((uint64_t)(w) << 60) | ((uint64_t)(d) << 40) | (uint64_t)(tick))
#define HN_W(k) ((int)((k) >> 60))
#define HN_D(k) ((int32_t)(((k) >> 40) & 0xFFFFF))

static inline int hb_less(const hb_item *a, const hb_item *b) {
    return a->key < b->key || (a->key == b->key && a->tick < b->tick);
}
static inline int hn_less(const hn_item *a, const hn_item *b) { return a->key < b->key; }

#define HEAP_FUNCS(NAME, T, LESS)                                                            \
    static void NAME##_up(T *h, int64_t i) {                                                 \
        T x = h[i];                                                                          \
        while (i > 0) {                                                                      \
            int64_t p = (i - 1) >> 2;                                                        \
            if (!LESS(&x, &h[p])) break;                                                     \
            h[i] = h[p];                                                                     \
            i = p;                                                                           \
        }                                                                                    \
        h[i] = x;                                                                            \
    }                                                                                        \
    static T NAME##_pop(T *h, int64_t *n) {                                                  \
        T top = h[0];                                                                        \
        T x = h[--*n];                                                                       \
        int64_t m = *n, i = 0;                                                               \
        if (m == 0) return top;                                                              \
        for (;;) {                                                                           \
            int64_t c = 4 * i + 1;                                                           \
            if (c >= m) break;                                                               \
            int64_t e = c + 4 < m ? c + 4 : m, best = c;                                     \
            for (int64_t k = c + 1; k < e; k++)                                              \
                if (LESS(&h[k], &h[best])) best = k;                                         \
            if (!LESS(&h[best], &x)) break;                                                  \
            h[i] = h[best];                                                                  \
            i = best;                                                                        \
        }                                                                                    \
        h[i] = x;                                                                            \
        return top;                                                                          \
    }
HEAP_FUNCS(hb, hb_item, hb_less)
HEAP_FUNCS(hn, hn_item, hn_less)

/* ---- the search ----------------------------------------------------------------------------------- */
typedef struct { int32_t action; int32_t child; int64_t cost; uint8_t hit; } succ_t;
typedef struct { uint64_t key; double seen, exp; } sd_t;                 /* key UINT64_MAX: empty */
typedef struct { int32_t sid, parent, action, depth; double G; int64_t cost; } node_t;
/* What the search knows of a state, in one cache line's half: q_max (q_has), its successors in `succ`
 * (succn -1: not yet computed), its width as cached (w_has: w_val at tables version w_ver; 0 not novel),
 * and the stamp of the last flush that listed it. */
typedef struct {
    double q;
    int64_t succ0;
    int32_t succn, w_ver, mark;
    uint8_t q_has, w_has;
    int8_t w_val;
} sinfo_t;

typedef struct {
    bn_model m;
    int64_t W, budget, depth_cap, prefetch, task;
    double scale;
    double *gpow;                  /* depth_cap + 1 */
    int profile, tracing;
    bn_native_fn native;
    void *native_ctx;

    /* states: interned, id = sid */
    uint64_t *st;  int64_t st_cap, n_st;       /* n_st * W words */
    int32_t *st_tab; int64_t st_tab_cap;       /* open addressing: sid + 1, 0 empty */
    sinfo_t *si;                               /* per sid: its value, successors, width cache */
    int64_t sinfo_cap;
    succ_t *succ; int64_t succ_cap, n_succ;

    /* (sid, depth) -> best G admitted (seen) and G when expanded */
    sd_t *sd; int64_t sd_cap, sd_n;

    /* nodes */
    node_t *nd; int64_t n_cap, n_nodes;

    /* terminals */
    int32_t *t_sid, *t_depth, *t_parent, *t_action; double *t_G; int64_t *t_cost; int64_t t_cap, n_term;

    hb_item *hb; int64_t hb_cap, hb_n;
    hn_item *hn; int64_t hn_cap, hn_n;
    int32_t *pend_nid; int64_t *pend_tick; int64_t pend_cap, pend_n;   /* enqueued, not yet valued */

    /* novelty tables */
    uint64_t *nov_atoms, *nov_rows;            /* W, n_atoms * W */
    int64_t nov_version;

    /* flush */
    uint64_t *need; int32_t *need_sid; double *need_q; int64_t need_cap, need_n;
    int64_t flush_stamp;

    /* successor scratch */
    int64_t *act_stamp; int64_t act_call;
    uint64_t *tmp;                             /* 4 W scratch words */

    /* the loop */
    int64_t tick, e, phase, resume;

    /* stats */
    int64_t bellman, novelty, forfeited, stale, skipped, dropped, repushed, generated, value_calls, value_states;
    uint64_t k_sim, k_nov;                     /* section ticks */
    uint64_t k0; double s0;                    /* ticks and seconds at the start */
    double t_val;

    int8_t *tr_kind; int32_t *tr_node; int64_t tr_cap, tr_n;
    int err;
} bn_t;

static inline uint64_t hash_words(const uint64_t *s, int64_t W) {
    uint64_t h = 0x9e3779b97f4a7c15ULL;
    for (int64_t w = 0; w < W; w++) h = mix64(h ^ s[w]) + (uint64_t)w;
    return h;
}

static int sinfo_grow(bn_t *b, int64_t need) {
    if (need <= b->sinfo_cap) return 0;
    int64_t c = b->sinfo_cap ? b->sinfo_cap : 1024;
    while (c < need) c *= 2;
    sinfo_t *x = realloc(b->si, (size_t)c * sizeof(sinfo_t));
    if (!x) return -1;
    b->si = x;
    b->sinfo_cap = c;
    return 0;
}

static int st_rehash(bn_t *b, int64_t cap) {
    int32_t *t = calloc((size_t)cap, sizeof(int32_t));
    if (!t) return -1;
    for (int64_t i = 0; i < b->n_st; i++) {
        uint64_t h = hash_words(b->st + i * b->W, b->W) & (uint64_t)(cap - 1);
        while (t[h]) h = (h + 1) & (uint64_t)(cap - 1);
        t[h] = (int32_t)(i + 1);
    }
    free(b->st_tab);
    b->st_tab = t;
    b->st_tab_cap = cap;
    return 0;
}

/* The id of a state, interned on first sight (-1: out of memory). */
static int32_t intern(bn_t *b, const uint64_t *s) {
    int64_t W = b->W;
    if (2 * (b->n_st + 1) > b->st_tab_cap && st_rehash(b, b->st_tab_cap ? 2 * b->st_tab_cap : 4096)) return -1;
    uint64_t mask = (uint64_t)(b->st_tab_cap - 1), h = hash_words(s, W) & mask;
    for (;;) {
        int32_t e = b->st_tab[h];
        if (!e) break;
        const uint64_t *t = b->st + (int64_t)(e - 1) * W;
        int64_t w = 0;
        while (w < W && t[w] == s[w]) w++;
        if (w == W) return e - 1;
        h = (h + 1) & mask;
    }
    int64_t id = b->n_st;
    if (GROW(b->st, b->st_cap, (id + 1) * W) || sinfo_grow(b, id + 1)) return -1;
    memcpy(b->st + id * W, s, (size_t)W * 8);
    sinfo_t z = {0.0, 0, -1, 0, 0, 0, 0, 0};
    b->si[id] = z;
    b->st_tab[h] = (int32_t)(id + 1);
    b->n_st = id + 1;
    return (int32_t)id;
}

/* (sid, depth) table */
static inline uint64_t sd_keyof(int32_t sid, int32_t d) { return ((uint64_t)(uint32_t)sid << 20) | (uint64_t)(uint32_t)d; }

static int sd_rehash(bn_t *b, int64_t cap) {
    sd_t *t = malloc((size_t)cap * sizeof(sd_t));
    if (!t) return -1;
    for (int64_t i = 0; i < cap; i++) t[i].key = UINT64_MAX;
    for (int64_t i = 0; i < b->sd_cap; i++) {
        if (b->sd[i].key == UINT64_MAX) continue;
        uint64_t h = mix64(b->sd[i].key) & (uint64_t)(cap - 1);
        while (t[h].key != UINT64_MAX) h = (h + 1) & (uint64_t)(cap - 1);
        t[h] = b->sd[i];
    }
    free(b->sd);
    b->sd = t;
    b->sd_cap = cap;
    return 0;
}

/* The entry of (sid, depth), created with seen = expanded = -inf (NULL: out of memory). */
static sd_t *sd_slot(bn_t *b, int32_t sid, int32_t d) {
    if (2 * (b->sd_n + 1) > b->sd_cap && sd_rehash(b, b->sd_cap ? 2 * b->sd_cap : 8192)) return NULL;
    uint64_t key = sd_keyof(sid, d), mask = (uint64_t)(b->sd_cap - 1), h = mix64(key) & mask;
    while (b->sd[h].key != UINT64_MAX) {
        if (b->sd[h].key == key) return &b->sd[h];
        h = (h + 1) & mask;
    }
    sd_t *e = &b->sd[h];
    e->key = key; e->seen = -INFINITY; e->exp = -INFINITY;
    b->sd_n++;
    return e;
}

/* The expanded G of (sid, depth) without creating it. */
static double sd_expanded(bn_t *b, int32_t sid, int32_t d) {
    if (!b->sd_cap) return -INFINITY;
    uint64_t key = sd_keyof(sid, d), mask = (uint64_t)(b->sd_cap - 1), h = mix64(key) & mask;
    while (b->sd[h].key != UINT64_MAX) {
        if (b->sd[h].key == key) return b->sd[h].exp;
        h = (h + 1) & mask;
    }
    return -INFINITY;
}

static inline int goal(const bn_model *m, const uint64_t *s) {
    int64_t W = m->W;
    for (int64_t g = 0; g < m->n_goals; g++) {
        const uint64_t *p = m->g_pos + g * W, *n = m->g_neg + g * W;
        int ok = 1;
        for (int64_t w = 0; w < W; w++)
            if ((s[w] & p[w]) != p[w] || (s[w] & n[w])) { ok = 0; break; }
        if (ok) return 1;
    }
    return 0;
}

static inline int applicable(const uint64_t *s, const uint64_t *p, const uint64_t *n, int64_t W) {
    for (int64_t w = 0; w < W; w++)
        if ((s[w] & p[w]) != p[w] || (s[w] & n[w])) return 0;
    return 1;
}

static int add_succ(bn_t *b, int64_t e, const uint64_t *s) {
    const bn_model *m = &b->m;
    int64_t W = b->W;
    uint64_t *add = b->tmp, *del = b->tmp + W, *t = b->tmp + 2 * W;
    memcpy(add, m->e_add + e * W, (size_t)W * 8);
    memcpy(del, m->e_del + e * W, (size_t)W * 8);
    for (int32_t c = m->e_cond0[e], ce = c + m->e_condn[e]; c < ce; c++)
        if (applicable(s, m->c_pos + (int64_t)c * W, m->c_neg + (int64_t)c * W, W))
            for (int64_t w = 0; w < W; w++) { add[w] |= m->c_add[c * W + w]; del[w] |= m->c_del[c * W + w]; }
    for (int64_t w = 0; w < W; w++) t[w] = (s[w] & ~del[w]) | add[w];
    int32_t child = intern(b, t);
    if (child < 0 || GROW(b->succ, b->succ_cap, b->n_succ + 1)) return -1;
    succ_t *x = &b->succ[b->n_succ++];
    x->action = m->e_action[e]; x->child = child; x->cost = m->e_cost[e];
    x->hit = (uint8_t)goal(m, t);
    return 0;
}

static int scan(bn_t *b, int64_t lo, int64_t hi, const uint64_t *s) {
    const bn_model *m = &b->m;
    int64_t W = b->W;
    for (int64_t e = lo; e < hi; e++) {
        if (!applicable(s, m->e_pos + e * W, m->e_neg + e * W, W)) continue;
        if (m->e_multi[e]) {
            int32_t a = m->e_action[e];
            if (b->act_stamp[a] == b->act_call) continue;
            b->act_stamp[a] = b->act_call;
        }
        if (add_succ(b, e, s)) return -1;
    }
    return 0;
}

/* EXPANSION_OF: the successors of a state, computed once (Model.successors' order). */
static int expansion_of(bn_t *b, int32_t sid) {
    if (b->si[sid].succn >= 0) return 0;
    uint64_t t0 = b->profile ? ticks() : 0;
    int64_t W = b->W;
    uint64_t s[64];
    memcpy(s, b->st + (int64_t)sid * W, (size_t)W * 8);      /* intern() may move b->st */
    int64_t start = b->n_succ;
    b->act_call++;
    if (scan(b, 0, b->m.n_always, s)) return -1;
    for (int64_t w = 0; w < W; w++) {
        uint64_t x = s[w];
        while (x) {
            int64_t i = w * 64 + __builtin_ctzll(x);
            x &= x - 1;
            if (i < b->m.n_atoms && scan(b, b->m.trig0[i], b->m.trig0[i + 1], s)) return -1;
        }
    }
    b->si[sid].succ0 = start;
    b->si[sid].succn = (int32_t)(b->n_succ - start);
    if (b->profile) b->k_sim += ticks() - t0;
    return 0;
}

/* ---- novelty -------------------------------------------------------------------------------------- */
/* 1, 2, or 0 (not novel); `added` NULL: exact, else only pairs with an atom in `added`. */
static int width_raw(bn_t *b, const uint64_t *s, const uint64_t *added) {
    int64_t W = b->W;
    for (int64_t w = 0; w < W; w++)
        if (s[w] & ~b->nov_atoms[w]) return 1;
    for (int64_t w = 0; w < W; w++) {
        uint64_t x = added ? (s[w] & added[w]) : s[w];
        while (x) {
            int64_t i = w * 64 + __builtin_ctzll(x);
            x &= x - 1;
            const uint64_t *row = b->nov_rows + i * W;
            for (int64_t v = 0; v < W; v++)
                if (s[v] & ~row[v]) return 2;
        }
    }
    return 0;
}

static int width_of(bn_t *b, int32_t sid, const uint64_t *added) {
    sinfo_t *i = &b->si[sid];
    if (i->w_has && (i->w_val == 0 || i->w_ver == (int32_t)b->nov_version)) return i->w_val;
    uint64_t t0 = b->profile ? ticks() : 0;
    int w = width_raw(b, b->st + (int64_t)sid * b->W, added);
    if (b->profile) b->k_nov += ticks() - t0;
    i->w_has = 1; i->w_ver = (int32_t)b->nov_version; i->w_val = (int8_t)w;
    return w;
}

static void nov_register(bn_t *b, const uint64_t *s) {
    int64_t W = b->W;
    int changed = 0;
    for (int64_t w = 0; w < W; w++) {
        uint64_t x = s[w];
        while (x) {
            int64_t i = w * 64 + __builtin_ctzll(x);
            x &= x - 1;
            uint64_t *row = b->nov_rows + i * W;
            int miss = 0;
            for (int64_t v = 0; v < W; v++) if (s[v] & ~row[v]) { miss = 1; break; }
            if (miss) {
                for (int64_t v = 0; v < W; v++) row[v] |= s[v];
                changed = 1;
            }
        }
    }
    for (int64_t w = 0; w < W; w++) b->nov_atoms[w] |= s[w];
    if (changed) b->nov_version++;
}

/* ---- nodes, terminals, trace ---------------------------------------------------------------------- */
static int32_t new_node(bn_t *b, int32_t sid, int32_t parent, int32_t action, int32_t d, double G, int64_t c) {
    int64_t i = b->n_nodes;
    if (GROW(b->nd, b->n_cap, i + 1)) return -1;
    node_t x = {sid, parent, action, d, G, c};
    b->nd[i] = x;
    b->n_nodes = i + 1;
    return (int32_t)i;
}

/* The next tick (-1: past 2^32 pushes). */
static int64_t next_tick(bn_t *b) {
    if (b->tick >= (int64_t)UINT32_MAX) return -1;
    return b->tick++;
}

/* TRYADDTERMINAL */
static int admit_terminal(bn_t *b, int32_t sid, int32_t d, double G, int64_t c, int32_t parent, int32_t action) {
    sd_t *e = sd_slot(b, sid, d);
    if (!e) return -1;
    if (e->seen >= G) return 0;                /* -inf when unseen: G is finite */
    e->seen = G;
    int64_t i = b->n_term;
    if (i + 1 > b->t_cap) {
        int64_t c2 = b->t_cap ? 2 * b->t_cap : 256;
#define RE(p) do { void *x = realloc(p, (size_t)c2 * sizeof(*(p))); if (!x) return -1; p = x; } while (0)
        RE(b->t_sid); RE(b->t_depth); RE(b->t_parent); RE(b->t_action); RE(b->t_G); RE(b->t_cost);
#undef RE
        b->t_cap = c2;
    }
    b->t_sid[i] = sid; b->t_depth[i] = d; b->t_G[i] = G; b->t_cost[i] = c; b->t_parent[i] = parent;
    b->t_action[i] = action;
    b->n_term = i + 1;
    return 0;
}

static int trace(bn_t *b, int kind, int32_t nid) {
    if (!b->tracing) return 0;
    if (b->tr_n + 1 > b->tr_cap) {
        int64_t c2 = b->tr_cap ? 2 * b->tr_cap : 1024;
        int8_t *k = realloc(b->tr_kind, (size_t)c2);
        if (!k) return -1;
        b->tr_kind = k;
        int32_t *n = realloc(b->tr_node, (size_t)c2 * sizeof(int32_t));
        if (!n) return -1;
        b->tr_node = n;
        b->tr_cap = c2;
    }
    b->tr_kind[b->tr_n] = (int8_t)kind;
    b->tr_node[b->tr_n++] = nid;
    return 0;
}

static int pend(bn_t *b, int32_t nid) {
    int64_t t = next_tick(b), cap = b->pend_cap;
    if (t < 0 || GROW(b->pend_nid, b->pend_cap, b->pend_n + 1)) return -1;
    if (b->pend_cap != cap) {
        int64_t *x = realloc(b->pend_tick, (size_t)b->pend_cap * sizeof(int64_t));
        if (!x) return -1;
        b->pend_tick = x;
    }
    b->pend_nid[b->pend_n] = nid;
    b->pend_tick[b->pend_n++] = t;
    return 0;
}

static int push_hn(bn_t *b, int w, int32_t d, int32_t nid) {
    int64_t t = next_tick(b);
    if (t < 0 || d >= (1 << 20) || GROW(b->hn, b->hn_cap, b->hn_n + 1)) return -1;
    hn_item x = {HN_KEY(w, d, t), nid, 0};
    b->hn[b->hn_n] = x;
    hn_up(b->hn, b->hn_n++);
    return 0;
}

/* EXPAND */
static int expand(bn_t *b, int32_t nid, int registered) {
    node_t n = b->nd[nid];
    int32_t sid = n.sid, d = n.depth;
    double G = n.G;
    int64_t c = n.cost, W = b->W;
    sd_t *e = sd_slot(b, sid, d);
    if (!e) return -1;
    e->exp = G;
    if (expansion_of(b, sid)) return -1;
    int32_t d1 = d + 1;
    double disc = b->gpow[d] / b->scale;
    int is_open = d1 < b->depth_cap;
    int64_t s0 = b->si[sid].succ0, sn = b->si[sid].succn;
    uint64_t added[64];
    if (is_open && 2 * (b->sd_n + sn + 1) <= b->sd_cap) {       /* the children's (state, depth) entries: */
        uint64_t mask = (uint64_t)(b->sd_cap - 1);                 /* fetched at once, not one miss at a time */
        for (int64_t k = 0; k < sn; k++)
            __builtin_prefetch(&b->sd[mix64(sd_keyof(b->succ[s0 + k].child, d1)) & mask]);
    }
    for (int64_t k = 0; k < sn; k++) {
        succ_t x = b->succ[s0 + k];
        double G2 = G - disc * (double)x.cost;
        if (x.hit) {
            if (admit_terminal(b, x.child, d1, G2, c + x.cost, nid, x.action)) return -1;
            continue;
        }
        if (!is_open) continue;
        sd_t *f = sd_slot(b, x.child, d1);
        if (!f) return -1;
        if (G2 <= f->seen) continue;                         /* -inf when unseen */
        f->seen = G2;
        int32_t child = new_node(b, x.child, nid, x.action, d1, G2, c + x.cost);
        if (child < 0 || pend(b, child)) return -1;
        int w;
        if (registered) {
            const uint64_t *s2 = b->st + (int64_t)x.child * W, *s = b->st + (int64_t)sid * W;
            for (int64_t v = 0; v < W; v++) added[v] = s2[v] & ~s[v];
            w = width_of(b, x.child, added);
        } else {
            w = width_of(b, x.child, NULL);
        }
        if (w && push_hn(b, w, d1, child)) return -1;
    }
    b->generated += sn;
    return 0;
}

/* The first half of a flush: the states to value (need, then prefetched children). */
static int flush_need(bn_t *b) {
    int64_t W = b->W, stamp = ++b->flush_stamp;
    b->need_n = 0;
    for (int64_t i = 0; i < b->pend_n; i++) {
        int32_t sid = b->nd[b->pend_nid[i]].sid;
        if (b->si[sid].q_has || b->si[sid].mark == (int32_t)stamp) continue;
        b->si[sid].mark = (int32_t)stamp;
        if (GROW(b->need_sid, b->need_cap, b->need_n + 1)) return -1;
        b->need_sid[b->need_n++] = sid;
    }
    int64_t n0 = b->need_n;
    if (n0 && b->prefetch > n0) {
        int64_t room = b->prefetch - n0;
        for (int64_t i = 0; i < n0; i++) {
            int32_t sid = b->need_sid[i];
            if (expansion_of(b, sid)) return -1;               /* every need state's successors, as Python */
            int64_t s0 = b->si[sid].succ0, sn = b->si[sid].succn;
            for (int64_t k = 0; k < sn && room > 0; k++) {
                succ_t x = b->succ[s0 + k];
                if (x.hit || b->si[x.child].q_has || b->si[x.child].mark == (int32_t)stamp) continue;
                b->si[x.child].mark = (int32_t)stamp;
                if (GROW(b->need_sid, b->need_cap, b->need_n + 1)) return -1;
                b->need_sid[b->need_n++] = x.child;
                room--;
            }
        }
    }
    if (b->need_n) {
        int64_t cap = b->need_n;
        uint64_t *s = realloc(b->need, (size_t)cap * W * 8);
        double *q = realloc(b->need_q, (size_t)cap * 8);
        if (!s || !q) { if (s) b->need = s; if (q) b->need_q = q; return -1; }
        b->need = s; b->need_q = q;
        for (int64_t i = 0; i < b->need_n; i++) memcpy(s + i * W, b->st + (int64_t)b->need_sid[i] * W, (size_t)W * 8);
    }
    return 0;
}

/* The second half: store the values, push the pending nodes on H_B with their enqueue ticks. */
static int flush_push(bn_t *b) {
    if (b->need_n) {
        for (int64_t i = 0; i < b->need_n; i++) { b->si[b->need_sid[i]].q = b->need_q[i]; b->si[b->need_sid[i]].q_has = 1; }
        b->value_calls++;
        b->value_states += b->need_n;
        b->need_n = 0;
    }
    if (GROW(b->hb, b->hb_cap, b->hb_n + b->pend_n)) return -1;
    for (int64_t i = 0; i < b->pend_n; i++) {
        const node_t *n = &b->nd[b->pend_nid[i]];
        hb_item x = {-(n->G + b->gpow[n->depth] * b->si[n->sid].q), (uint32_t)b->pend_tick[i], b->pend_nid[i]};
        b->hb[b->hb_n] = x;
        hb_up(b->hb, b->hb_n++);
    }
    b->pend_n = 0;
    return 0;
}

/* NOVELTYPOP: -1 when the heap runs dry */
static int32_t novelty_pop(bn_t *b) {
    while (b->hn_n) {
        hn_item it = hn_pop(b->hn, &b->hn_n);
        uint64_t x = it.key;
        int32_t nid = it.nid, d = HN_D(x);
        const node_t *n = &b->nd[nid];
        if (d >= b->depth_cap || sd_expanded(b, n->sid, d) >= n->G) { b->skipped++; continue; }
        int w = width_of(b, n->sid, NULL);
        if (!w) { b->dropped++; continue; }
        if (w > HN_W(x)) {
            if (push_hn(b, w, d, nid)) { b->err = 1; return -1; }
            b->repushed++;
            continue;
        }
        return nid;
    }
    return -1;
}

/* ---- the interface -------------------------------------------------------------------------------- */
bn_t *bn_new(const bn_model *m, int64_t budget, int64_t depth_cap, const double *gpow, double scale,
             int64_t prefetch, int64_t task, int profile, int tracing) {
    bn_t *b = calloc(1, sizeof(bn_t));
    if (!b) return NULL;
    b->m = *m;
    b->W = m->W; b->budget = budget; b->depth_cap = depth_cap; b->scale = scale; b->prefetch = prefetch;
    b->task = task; b->profile = profile; b->tracing = tracing;
    b->gpow = malloc((size_t)(depth_cap + 1) * sizeof(double));
    b->nov_atoms = calloc((size_t)m->W, 8);
    b->nov_rows = calloc((size_t)(m->n_atoms > 0 ? m->n_atoms : 1) * (size_t)m->W, 8);
    b->act_stamp = calloc((size_t)(m->n_actions > 0 ? m->n_actions : 1), sizeof(int64_t));
    b->tmp = calloc((size_t)m->W * 4, 8);
    if (!b->gpow || !b->nov_atoms || !b->nov_rows || !b->act_stamp || !b->tmp || m->W > 64) return NULL;
    memcpy(b->gpow, gpow, (size_t)(depth_cap + 1) * sizeof(double));
    return b;
}

void bn_set_native(bn_t *b, bn_native_fn fn, void *ctx) { b->native = fn; b->native_ctx = ctx; }

void bn_free(bn_t *b) {
    if (!b) return;
    void *ps[] = {b->gpow, b->st, b->st_tab, b->si, b->succ, b->sd, b->nd, b->pend_nid, b->t_sid, b->t_depth, b->t_parent, b->t_action,
                  b->t_G, b->t_cost, b->hb, b->hn, b->pend_tick, b->nov_atoms, b->nov_rows, b->need,
                  b->need_sid, b->need_q, b->act_stamp, b->tmp, b->tr_kind, b->tr_node};
    for (size_t i = 0; i < sizeof(ps) / sizeof(ps[0]); i++) free(ps[i]);
    free(b);
}

/* Lines 2-4: the reference terminal (if any, admitted first), then the root. */
int bn_start(bn_t *b, const uint64_t *root, int has_ref, const uint64_t *ref_state, int64_t ref_depth,
             double ref_G, int64_t ref_cost) {
    b->k0 = ticks();
    b->s0 = now();
    if (has_ref) {
        int32_t r = intern(b, ref_state);
        if (r < 0 || admit_terminal(b, r, (int32_t)ref_depth, ref_G, ref_cost, -1, -1)) return BN_ENOMEM;
    }
    int32_t sid = intern(b, root);
    if (sid < 0) return BN_ENOMEM;
    if (goal(&b->m, root)) {
        if (admit_terminal(b, sid, 0, 0.0, 0, -1, -1)) return BN_ENOMEM;
    } else if (b->depth_cap > 0) {
        sd_t *e = sd_slot(b, sid, 0);
        if (!e) return BN_ENOMEM;
        e->seen = 0.0;
        int32_t nid = new_node(b, sid, -1, -1, 0, 0.0, 0);
        if (nid < 0 || pend(b, nid)) return BN_ENOMEM;
        int w = width_of(b, sid, NULL);
        if (w && push_hn(b, w, 0, nid)) return BN_ENOMEM;
    }
    return BN_DONE;
}

/* Lines 5-18. BN_NEED: value `need` (need_n states) into need_q and call again. */
int bn_run(bn_t *b) {
    if (b->resume) {
        b->resume = 0;
        goto resume_flush;
    }
    while (b->e < b->budget && (b->hb_n || b->pend_n || b->hn_n)) {
        if (b->phase < 3) {                                            /* Bellman turn */
            b->phase = (b->phase + 1) % 4;
            if (b->pend_n) {
                if (flush_need(b)) return BN_ENOMEM;
                if (b->need_n) {
                    if (!b->native) {
                        b->resume = 1;
                        return BN_NEED;
                    }
                    double t0 = now();
                    if (b->native(b->native_ctx, b->task, b->need, b->need_n, b->W, b->need_q)) return BN_EVALUE;
                    b->t_val += now() - t0;
                }
            resume_flush:
                if (flush_push(b)) return BN_ENOMEM;
            }
            if (!b->hb_n) {
                b->forfeited++;
                if (trace(b, 2, -1)) return BN_ENOMEM;
                continue;
            }
            hb_item x = hb_pop(b->hb, &b->hb_n);
            int32_t nid = x.nid, d = b->nd[nid].depth;
            if (d >= b->depth_cap || sd_expanded(b, b->nd[nid].sid, d) >= b->nd[nid].G) {
                b->stale++;
                if (trace(b, 3, nid)) return BN_ENOMEM;
                continue;
            }
            b->e++;
            b->bellman++;
            if (trace(b, 0, nid) || expand(b, nid, 0)) return BN_ENOMEM;
        } else {                                                        /* novelty turn */
            b->phase = 0;
            int32_t nid = novelty_pop(b);
            if (b->err) return BN_ENOMEM;
            if (nid < 0) continue;
            uint64_t t0 = b->profile ? ticks() : 0;
            nov_register(b, b->st + (int64_t)b->nd[nid].sid * b->W);
            if (b->profile) b->k_nov += ticks() - t0;
            b->e++;
            b->novelty++;
            if (trace(b, 1, nid) || expand(b, nid, 1)) return BN_ENOMEM;
        }
    }
    return BN_DONE;
}

/* ---- results -------------------------------------------------------------------------------------- */
typedef struct {
    int64_t expansions, bellman, novelty, forfeited, stale, skipped, dropped, repushed, generated, nodes;
    int64_t terminals, value_calls, value_states, states, trace;
    double t_sim, t_nov, t_val;
} bn_stats;

void bn_get_stats(const bn_t *b, bn_stats *s) {
    s->expansions = b->e; s->bellman = b->bellman; s->novelty = b->novelty; s->forfeited = b->forfeited;
    s->stale = b->stale; s->skipped = b->skipped; s->dropped = b->dropped; s->repushed = b->repushed;
    s->generated = b->generated; s->nodes = b->n_nodes; s->terminals = b->n_term;
    s->value_calls = b->value_calls; s->value_states = b->value_states; s->states = b->n_st;
    s->trace = b->tr_n; s->t_val = b->t_val;
    uint64_t k = ticks() - b->k0;
    double per = k ? (now() - b->s0) / (double)k : 0.0;       /* seconds per tick over the search */
    s->t_sim = (double)b->k_sim * per;
    s->t_nov = (double)b->k_nov * per;
}

int64_t bn_need(const bn_t *b, uint64_t **states, double **q) {
    *states = b->need;
    *q = b->need_q;
    return b->need_n;
}

void bn_add_value_time(bn_t *b, double t) { b->t_val += t; }

/* Terminals: their states (W words each), depth, G, cost, parent node and action (-1 for none). */
void bn_get_terminals(const bn_t *b, uint64_t *states, int32_t *depth, double *G, int64_t *cost, int32_t *parent,
                      int32_t *action) {
    for (int64_t i = 0; i < b->n_term; i++) {
        memcpy(states + i * b->W, b->st + (int64_t)b->t_sid[i] * b->W, (size_t)b->W * 8);
        depth[i] = b->t_depth[i]; G[i] = b->t_G[i]; cost[i] = b->t_cost[i];
        parent[i] = b->t_parent[i]; action[i] = b->t_action[i];
    }
}

/* A node's plan: the actions from the root, written backwards into out (at most cap); the length. */
int64_t bn_plan(const bn_t *b, int32_t nid, int32_t *out, int64_t cap) {
    int64_t n = 0;
    while (nid >= 0 && b->nd[nid].parent >= 0 && n < cap) {
        out[n++] = b->nd[nid].action;
        nid = b->nd[nid].parent;
    }
    return n;
}

/* The trace: kind (0 bellman, 1 novelty, 2 forfeit, 3 stale), the node's state and depth. */
void bn_get_trace(const bn_t *b, int8_t *kind, uint64_t *states, int32_t *depth) {
    for (int64_t i = 0; i < b->tr_n; i++) {
        int32_t nid = b->tr_node[i];
        kind[i] = b->tr_kind[i];
        if (nid >= 0) {
            memcpy(states + i * b->W, b->st + (int64_t)b->nd[nid].sid * b->W, (size_t)b->W * 8);
            depth[i] = b->nd[nid].depth;
        } else {
            memset(states + i * b->W, 0, (size_t)b->W * 8);
            depth[i] = -1;
        }
    }
}

/* The successors of one state as the search sees them, for checking against Model.successors:
 * writes up to cap (action, cost) pairs and next states; returns the count (-1: out of memory). */
int64_t bn_successors(bn_t *b, const uint64_t *s, int32_t *action, int64_t *cost, uint64_t *next, uint8_t *hit,
                      int64_t cap) {
    int32_t sid = intern(b, s);
    if (sid < 0 || expansion_of(b, sid)) return -1;
    int64_t s0 = b->si[sid].succ0, n = b->si[sid].succn;
    for (int64_t k = 0; k < n && k < cap; k++) {
        succ_t x = b->succ[s0 + k];
        action[k] = x.action; cost[k] = x.cost; hit[k] = x.hit;
        memcpy(next + k * b->W, b->st + (int64_t)x.child * b->W, (size_t)b->W * 8);
    }
    return n;
}
