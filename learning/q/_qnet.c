/* max_a Q(s, tau, a) of the factored dueling Q-network (learning/q/network.py; its engine NativeQ in learning/q/inference.py) for int-bitset states, in C.
 *
 * The same function as BatchedQ.q_max (see its docstring for the structure):
 *   h1 = relu(b1 + task part + sum of the atom columns of layer 1      float32
 *             + the task's goal-object columns of its true atoms)     (Encoding.paired)
 *   h2 = relu(b2 + W2 h1)                                                float32
 *   V  = bv + wv . relu(bv1 + Wv1 h2)                                    float64
 *   per live (head, prefix) segment with two or more valid values: the advantages of its valid
 *   values y = b_col + w_col . relu(bh + Wh h2 + prefix term), centred on their mean;
 *   Q - V of a valid precondition variant = the sum of its columns' centred advantages
 *   (a segment with one valid value adds exactly 0); q_max = V + the max over valid variants
 *   (-inf where none is valid), V alone where the task's goal already holds.
 * Every state is computed on its own, with its sums in a fixed order, so its value does not
 * depend on the batch it comes in (unlike a BLAS product, whose rounding does); states are
 * taken in blocks of up to BLOCK only so that they share each weight row while it is in cache.
 * Built with -ffp-contract=off (planning/search/native.py): no fused multiply-adds, so the
 * value is the same on every x86 machine whatever the vector width.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define BLOCK 8

typedef struct {
    int64_t W, n_atoms, hid, H, n_live, n_seg, n_col, n_var, n_tasks;
    const float *w1;                 /* n_atoms x hid: layer 1's column of each atom */
    const float *b1t;                /* n_tasks x hid: layer 1's bias plus each task's part */
    const float *w2, *b2;            /* hid x hid (input-major), hid */
    const float *wv1;                /* hid x H: the value stream (float32 weights, float64 sums) */
    const double *bv1, *wv;          /* H, H */
    double bv;
    const float *wh, *bh;            /* n_live x hid x H, n_live x H: each live head's state part */
    const int32_t *seg_head;         /* n_seg: its live head */
    const float *seg_pref;           /* n_seg x H: its prefix term */
    const int32_t *col_seg;          /* n_col: the segment of each (segment, value) column */
    const float *col_w, *col_b;      /* n_col x H, n_col: the value's output row */
    const uint64_t *var_pos, *var_neg;          /* n_var x W: each precondition variant */
    const int32_t *trig0, *trig_var;            /* the variants to test when atom i holds: trig_var[trig0[i]..] */
    const int32_t *always;                      /* the variants without a positive atom (n_always of them) */
    int64_t n_always;
    const int32_t *var_col0, *var_coln, *var_cols;   /* its columns (CSR) */
    const int32_t *goal0, *goaln;    /* per task: its goal bindings in goal_pos / goal_neg */
    const uint64_t *goal_pos, *goal_neg;
    void *memo;                      /* NULL, or a qnet_memo (below) */
    /* goal-object features (Encoding.paired): per task, (atom, feature) pairs (CSR: obj0, n_tasks + 1);
       a true atom adds its feature's column of layer 1 (wobj, n_obj_feat x hid) */
    const int32_t *obj0, *obj_atom, *obj_feat;
    const float *wobj;
} qnet_t;

static inline int holds(const uint64_t *s, const uint64_t *p, const uint64_t *n, int64_t W) {
    for (int64_t w = 0; w < W; w++)
        if ((s[w] & p[w]) != p[w] || (s[w] & n[w])) return 0;
    return 1;
}

/* acc[b][j] = bias[j] + sum over k of x[b][k] * w[k][j], k ascending, for the BLOCK rows of a block
 * (unused rows are zeros). Register-blocked with GCC vector types, which the compiler maps to
 * whatever vector width the machine has; the sums run in the same order in every lane and on
 * every width, and a term with x = 0 adds a signed zero (what it would change, the sign of a
 * zero sum, does not survive the ReLU that follows every use). */
typedef float vf16 __attribute__((vector_size(64), aligned(4)));
typedef double vd8 __attribute__((vector_size(64), aligned(8)));

/* DENSE(NAME, B, C, T, V, WS, WV, L): acc (B x outn, type T) = bias + x (B x in, float) . w (in x outn,
 * stored as WS, read as WV vectors and converted to V), k ascending; V the vector type of L lanes, C vectors
 * of outputs per pass (B * C independent sums in flight). One function per row count B so that a block of
 * fewer rows costs less. A k where every row's x is 0 is skipped (about half of them: the ReLU's dead units),
 * a term x = 0 in a row adds a signed zero; neither changes a row's result after the ReLU that follows every
 * use, so a row's value does not depend on B, C or the other rows. The weights are stored as the network
 * holds them (float32), also for the float64 value stream: a float32 product is exact in float64. */
#define DENSE(NAME, B, C, T, V, WS, L, CV, SW)                                                       \
    static void NAME(const float *x, int64_t in, const WS *w, const T *bias, int64_t outn, T *acc) { \
        int32_t ks[in > 0 ? in : 1];                                                                 \
        T xt[(in > 0 ? in : 1) * B];                                                                 \
        int64_t nk = 0;                                                                              \
        for (int64_t k = 0; k < in; k++) {                                                           \
            int z = 1;                                                                               \
            for (int b = 0; b < B; b++) z &= x[b * in + k] == 0.0f;                                  \
            if (z) continue;                                                                         \
            for (int b = 0; b < B; b++) xt[nk * B + b] = (T)x[b * in + k];                           \
            ks[nk++] = (int32_t)k;                                                                   \
        }                                                                                            \
        int64_t j = 0;                                                                               \
        for (; j + C * L <= outn; j += C * L) {                                                      \
            V a[B][C];                                                                               \
            for (int c = 0; c < C; c++) {                                                            \
                V bb = *(const V *)(bias + j + c * L);                                               \
                for (int b = 0; b < B; b++) a[b][c] = bb;                                            \
            }                                                                                        \
            for (int64_t t = 0; t < nk; t++) {                                                       \
                int64_t k = ks[t];                                                                   \
                const WS *row = w + k * outn + j;                                                    \
                for (int c = 0; c < C; c++) {                                                        \
                    V wc = CV(row + c * L);                                                          \
                    for (int b = 0; b < B; b++) a[b][c] = a[b][c] + xt[t * B + b] * wc;              \
                }                                                                                    \
            }                                                                                        \
            for (int b = 0; b < B; b++)                                                              \
                for (int c = 0; c < C; c++) *(V *)(acc + b * outn + j + c * L) = a[b][c];            \
        }                                                                                            \
        for (; j < outn; j++)                                                                        \
            for (int b = 0; b < B; b++) {                                                            \
                T a = bias[j];                                                                       \
                for (int64_t t = 0; t < nk; t++) a = a + (T)x[b * in + ks[t]] * (T)SW(w[ks[t] * outn + j]); \
                acc[b * outn + j] = a;                                                               \
            }                                                                                        \
    }

typedef float vf8 __attribute__((vector_size(32), aligned(4)));

/* One function per row count 1..BLOCK; C: output vectors per pass, fewer the more rows (registers). */
#if defined(__AVX512F__)
#define CWIDE 2                    /* 32 vector registers */
#else
#define CWIDE 1
#endif
#define DENSE8(P, C1, T, V, WS, L, CV, SW)                                                           \
    DENSE(P##1, 1, C1, T, V, WS, L, CV, SW)                                                          \
    DENSE(P##2, 2, 4, T, V, WS, L, CV, SW)                                                           \
    DENSE(P##3, 3, 2, T, V, WS, L, CV, SW)                                                           \
    DENSE(P##4, 4, 2, T, V, WS, L, CV, SW)                                                           \
    DENSE(P##5, 5, CWIDE, T, V, WS, L, CV, SW)                                                       \
    DENSE(P##6, 6, CWIDE, T, V, WS, L, CV, SW)                                                       \
    DENSE(P##7, 7, CWIDE, T, V, WS, L, CV, SW)                                                       \
    DENSE(P##8, 8, CWIDE, T, V, WS, L, CV, SW)                                                       \
    static void P(const float *x, int64_t nb, int64_t in, const WS *w, const T *bias, int64_t outn, T *acc) { \
        switch (nb) {                                                                                \
            case 1: P##1(x, in, w, bias, outn, acc); break;                                          \
            case 2: P##2(x, in, w, bias, outn, acc); break;                                          \
            case 3: P##3(x, in, w, bias, outn, acc); break;                                          \
            case 4: P##4(x, in, w, bias, outn, acc); break;                                          \
            case 5: P##5(x, in, w, bias, outn, acc); break;                                          \
            case 6: P##6(x, in, w, bias, outn, acc); break;                                          \
            case 7: P##7(x, in, w, bias, outn, acc); break;                                          \
            default: P##8(x, in, w, bias, outn, acc); break;                                         \
        }                                                                                            \
    }

#define AS_F16(p) (*(const vf16 *)(p))
#define F8_TO_D8(p) __builtin_convertvector(*(const vf8 *)(p), vd8)
#define SCALAR_F(x) (x)
DENSE8(dense_f, 4, float, vf16, float, 16, AS_F16, SCALAR_F)     /* float32 weights, float32 sums */
DENSE8(dense_d, 8, double, vd8, float, 8, F8_TO_D8, SCALAR_F)    /* float32 weights, float64 sums */

typedef int32_t vi16 __attribute__((vector_size(64), aligned(4)));
typedef int64_t vl8 __attribute__((vector_size(64), aligned(8)));

/* sum over j of relu(p[j] + r[j]) * w[j]: 16 lane sums (lane j % 16), then a fixed tree, then the tail. */
static float dot_relu_f(const float *p, const float *r, const float *w, int64_t n) {
    vf16 acc = {0};
    int64_t j = 0;
    for (; j + 16 <= n; j += 16) {
        vf16 t = *(const vf16 *)(p + j) + *(const vf16 *)(r + j);
        t = (vf16)((vi16)t & (t > 0.0f));
        acc = acc + t * *(const vf16 *)(w + j);
    }
    float l[16];
    memcpy(l, &acc, sizeof l);
    for (int h = 8; h; h >>= 1)
        for (int i = 0; i < h; i++) l[i] = l[i] + l[i + h];
    float out = l[0];
    for (; j < n; j++) {
        float t = p[j] + r[j];
        out = out + (t > 0.0f ? t : 0.0f) * w[j];
    }
    return out;
}

/* sum over j of relu(p[j]) * w[j] in float64, the same way (8 lanes). */
static double dot_relu_d(const double *p, const double *w, int64_t n) {
    vd8 acc = {0};
    int64_t j = 0;
    for (; j + 8 <= n; j += 8) {
        vd8 t = *(const vd8 *)(p + j);
        t = (vd8)((vl8)t & (t > 0.0));
        acc = acc + t * *(const vd8 *)(w + j);
    }
    double l[8];
    memcpy(l, &acc, sizeof l);
    for (int h = 4; h; h >>= 1)
        for (int i = 0; i < h; i++) l[i] = l[i] + l[i + h];
    double out = l[0];
    for (; j < n; j++) out = out + (p[j] > 0.0 ? p[j] : 0.0) * w[j];
    return out;
}

static void relu_f(float *x, int64_t n) {
    for (int64_t i = 0; i < n; i++) x[i] = x[i] > 0.0f ? x[i] : 0.0f;
}

/* Per-thread scratch buffers (slot 0: q_compute's, 1-3: the memo's), grown as needed and kept: no
 * allocation per call, and calls from several threads do not share them. */
static __thread char *scratch_mem[4];
static __thread size_t scratch_cap[4];

static void *scratch(int slot, size_t bytes) {
    if (bytes > scratch_cap[slot]) {
        size_t c = scratch_cap[slot] ? scratch_cap[slot] : 4096;
        while (c < bytes) c *= 2;
        char *m = aligned_alloc(64, c);
        if (!m) return NULL;
        free(scratch_mem[slot]);
        scratch_mem[slot] = m;
        scratch_cap[slot] = c;
    }
    return scratch_mem[slot];
}

static int q_compute(const qnet_t *q, int64_t task, const uint64_t *states, int64_t n, int64_t W, double *out) {
    int64_t hid = q->hid, H = q->H, NV = q->n_var, NC = q->n_col, NS = q->n_seg, NL = q->n_live;
    /* the thread's scratch, carved into 64-byte aligned pieces */
    size_t sizes[] = {sizeof(float) * (size_t)(BLOCK * hid), sizeof(float) * (size_t)(BLOCK * hid),
                      sizeof(double) * (size_t)(BLOCK * H), sizeof(float) * (size_t)(NL * BLOCK * H + 1),
                      sizeof(int32_t) * (size_t)(BLOCK * NV + 1), (size_t)(BLOCK * NC + 1), (size_t)NL + 1,
                      sizeof(int32_t) * (size_t)(BLOCK * NS + 1), BLOCK, sizeof(float) * (size_t)(NC + 1),
                      sizeof(double) * (size_t)(NS + 1), sizeof(int32_t) * BLOCK};
    size_t total = 0;
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) total += (sizes[i] + 63) / 64 * 64;
    char *mem = scratch(0, total), *at = mem;
    if (!mem) return -1;
#define CARVE(T, name, i) T *name = (T *)at; at += (sizes[i] + 63) / 64 * 64
    CARVE(float, h1, 0); CARVE(float, h2, 1); CARVE(double, pv, 2); CARVE(float, part, 3);
    CARVE(int32_t, valid, 4); CARVE(uint8_t, present, 5); CARVE(uint8_t, need, 6); CARVE(int32_t, count, 7);
    CARVE(int8_t, state, 8);                      /* per row: 0 compute, 1 goal holds (V), 2 nothing valid */
    CARVE(float, y, 9); CARVE(double, mean, 10); CARVE(int32_t, nvalid, 11);
#undef CARVE
    for (int64_t lo = 0; lo < n; lo += BLOCK) {
        int64_t nb = n - lo < BLOCK ? n - lo : BLOCK;
        memset(need, 0, (size_t)NL);
        for (int64_t b = 0; b < nb; b++) {
            const uint64_t *s = states + (lo + b) * W;
            /* layer 1: the task's bias row plus the columns of the true atoms, in atom order */
            float *a = h1 + b * hid;
            memcpy(a, q->b1t + task * hid, sizeof(float) * (size_t)hid);
            for (int64_t w = 0; w < W; w++) {
                uint64_t x = s[w];
                while (x) {
                    int64_t i = w * 64 + __builtin_ctzll(x);
                    x &= x - 1;
                    if (i >= q->n_atoms) continue;
                    const float *col = q->w1 + i * hid;
                    for (int64_t j = 0; j < hid; j++) a[j] = a[j] + col[j];
                }
            }
            for (int32_t p = q->obj0[task], pe = q->obj0[task + 1]; p < pe; p++) {
                int32_t i = q->obj_atom[p];
                if (!((s[i >> 6] >> (i & 63)) & 1)) continue;
                const float *col = q->wobj + (int64_t)q->obj_feat[p] * hid;
                for (int64_t j = 0; j < hid; j++) a[j] = a[j] + col[j];
            }
            relu_f(a, hid);
            /* the goal, the valid variants, the columns they use, each segment's count */
            int sat = 0;
            for (int32_t g = q->goal0[task], ge = g + q->goaln[task]; g < ge && !sat; g++)
                sat = holds(s, q->goal_pos + (int64_t)g * W, q->goal_neg + (int64_t)g * W, W);
            state[b] = 1;
            if (sat) continue;                              /* AUTO alone: every advantage centres to 0 */
            /* the valid variants: those of the always group and of the true atoms' groups that hold (a variant
             * is listed under one of its positive atoms, Model.trigger_groups) */
            int32_t *ok = valid + b * NV, nok = 0;
            uint8_t *pr = present + b * NC;
            int32_t *cn = count + b * NS;
            for (int64_t t = 0; t < q->n_always; t++) {
                int32_t j = q->always[t];
                if (holds(s, q->var_pos + (int64_t)j * W, q->var_neg + (int64_t)j * W, W)) ok[nok++] = j;
            }
            for (int64_t w = 0; w < W; w++) {
                uint64_t x = s[w];
                while (x) {
                    int64_t i = w * 64 + __builtin_ctzll(x);
                    x &= x - 1;
                    if (i >= q->n_atoms) continue;
                    for (int32_t t = q->trig0[i], te = q->trig0[i + 1]; t < te; t++) {
                        int32_t j = q->trig_var[t];
                        if (holds(s, q->var_pos + (int64_t)j * W, q->var_neg + (int64_t)j * W, W)) ok[nok++] = j;
                    }
                }
            }
            nvalid[b] = nok;
            state[b] = nok ? 0 : 2;
            if (!nok) continue;
            memset(pr, 0, (size_t)NC);
            for (int32_t t = 0; t < nok; t++)
                for (int32_t c = q->var_col0[ok[t]], ce = c + q->var_coln[ok[t]]; c < ce; c++) pr[q->var_cols[c]] = 1;
            memset(cn, 0, sizeof(int32_t) * (size_t)NS);
            for (int64_t c = 0; c < NC; c++) if (pr[c]) cn[q->col_seg[c]]++;
            for (int64_t g = 0; g < NS; g++) if (cn[g] >= 2) need[q->seg_head[g]] = 1;
        }
        dense_f(h1, nb, hid, q->w2, q->b2, hid, h2);
        relu_f(h2, nb * hid);
        dense_d(h2, nb, hid, q->wv1, q->bv1, H, pv);
        for (int64_t L = 0; L < NL; L++)                  /* the live heads some row of the block needs */
            if (need[L]) dense_f(h2, nb, hid, q->wh + L * hid * H, q->bh + L * H, H, part + L * BLOCK * H);
        for (int64_t b = 0; b < nb; b++) {
            double v = q->bv + dot_relu_d(pv + b * H, q->wv, H);
            if (state[b] == 1) { out[lo + b] = v; continue; }
            if (state[b] == 2) { out[lo + b] = -INFINITY; continue; }
            const int32_t *ok = valid + b * NV;
            const uint8_t *pr = present + b * NC;
            const int32_t *cn = count + b * NS;
            memset(mean, 0, sizeof(double) * (size_t)NS);
            for (int64_t c = 0; c < NC; c++) {
                int32_t sg = q->col_seg[c];
                if (!pr[c] || cn[sg] < 2) continue;
                const float *ph = part + (int64_t)q->seg_head[sg] * BLOCK * H + b * H;
                const float *pref = q->seg_pref + sg * H, *wc = q->col_w + c * H;
                float acc = q->col_b[c] + dot_relu_f(ph, pref, wc, H);
                y[c] = acc;
                mean[sg] = mean[sg] + (double)acc;
            }
            for (int64_t g = 0; g < NS; g++) if (cn[g] >= 2) mean[g] = mean[g] / (double)cn[g];
            double best = -INFINITY;
            for (int32_t t = 0; t < nvalid[b]; t++) {
                int32_t j = ok[t];
                double a = 0.0;
                for (int32_t c = q->var_col0[j], ce = c + q->var_coln[j]; c < ce; c++) {
                    int32_t col = q->var_cols[c], sg = q->col_seg[col];
                    if (cn[sg] >= 2) a = a + ((double)y[col] - mean[sg]);
                }
                if (a > best) best = a;
            }
            out[lo + b] = v + best;
        }
    }
    return 0;
}

/* ---- the memo: values already computed, across searches ------------------------------------------
 * q_max(s, tau) and V_AP(s) are functions of their arguments alone, so a value once computed is kept
 * (key: the state's words and the task; for V_AP a negative key per task distribution, -1 the layout's P) and returned as it is; consecutive searches of a
 * sequence revisit many states. Open addressing; cleared when half full, so it never holds more than
 * `cap` / 2 entries. */
typedef struct { int64_t W, cap, n; uint64_t *key; double *val; uint8_t *used; int64_t hits, misses; } qnet_memo;

void *qnet_memo_new(int64_t W, int64_t log2cap) {
    qnet_memo *m = calloc(1, sizeof(qnet_memo));
    if (!m) return NULL;
    m->W = W;
    m->cap = (int64_t)1 << log2cap;
    m->key = malloc((size_t)m->cap * (size_t)(W + 1) * 8);
    m->val = malloc((size_t)m->cap * 8);
    m->used = calloc((size_t)m->cap, 1);
    if (!m->key || !m->val || !m->used) { free(m->key); free(m->val); free(m->used); free(m); return NULL; }
    return m;
}

void qnet_memo_free(void *p) {
    qnet_memo *m = p;
    if (!m) return;
    free(m->key); free(m->val); free(m->used); free(m);
}

void qnet_memo_stats(void *p, int64_t *out) {
    qnet_memo *m = p;
    out[0] = m ? m->n : 0; out[1] = m ? m->hits : 0; out[2] = m ? m->misses : 0;
}

static inline uint64_t memo_hash(const uint64_t *s, int64_t W, int64_t task) {
    uint64_t h = (uint64_t)task * 0x9e3779b97f4a7c15ULL;
    for (int64_t w = 0; w < W; w++) {
        h ^= s[w] + 0x632be59bd9b4e019ULL + (h << 6) + (h >> 2);
        h *= 0xbf58476d1ce4e5b9ULL;
    }
    return h ^ (h >> 31);
}

/* The slot of (s, task): found (1) or where it would go (0). */
static int64_t memo_find(qnet_memo *m, const uint64_t *s, int64_t task, int *found) {
    int64_t W = m->W, mask = m->cap - 1, h = (int64_t)(memo_hash(s, W, task) & (uint64_t)mask);
    for (;;) {
        if (!m->used[h]) { *found = 0; return h; }
        const uint64_t *k = m->key + h * (W + 1);
        int64_t w = 0;
        while (w < W && k[w] == s[w]) w++;
        if (w == W && k[W] == (uint64_t)task) { *found = 1; return h; }
        h = (h + 1) & mask;
    }
}

static void memo_put(qnet_memo *m, const uint64_t *s, int64_t task, double v) {
    if (2 * (m->n + 1) > m->cap) {                      /* half full: start over */
        memset(m->used, 0, (size_t)m->cap);
        m->n = 0;
    }
    int found;
    int64_t h = memo_find(m, s, task, &found);
    if (found) return;
    uint64_t *k = m->key + h * (m->W + 1);
    memcpy(k, s, (size_t)m->W * 8);
    k[m->W] = (uint64_t)task;
    m->val[h] = v;
    m->used[h] = 1;
    m->n++;
}

/* out[i] from the memo where it is there; the rest computed by `fn` (with `arg`) and remembered. */
typedef int (*compute_fn)(const qnet_t *q, int64_t arg, const uint64_t *states, int64_t n, int64_t W, double *out,
                          const int32_t *support, const double *prob, int64_t K);

static int memoized(const qnet_t *q, int64_t key, int64_t arg, const uint64_t *states, int64_t n, int64_t W,
                    double *out, compute_fn fn, const int32_t *support, const double *prob, int64_t K) {
    qnet_memo *m = q->memo;
    if (!m || m->W != W) return fn(q, arg, states, n, W, out, support, prob, K);
    int64_t *idx = scratch(1, sizeof(int64_t) * (size_t)(n > 0 ? n : 1));
    uint64_t *miss = scratch(2, sizeof(uint64_t) * (size_t)(n > 0 ? n : 1) * (size_t)W);
    double *got = scratch(3, sizeof(double) * (size_t)(n > 0 ? n : 1));
    if (!idx || !miss || !got) return -1;
    int64_t nm = 0;
    for (int64_t i = 0; i < n; i++) {
        int found;
        int64_t h = memo_find(m, states + i * W, key, &found);
        if (found) { out[i] = m->val[h]; m->hits++; continue; }
        memcpy(miss + nm * W, states + i * W, (size_t)W * 8);
        idx[nm++] = i;
    }
    int rc = 0;
    if (nm) {
        m->misses += nm;
        rc = fn(q, arg, miss, nm, W, got, support, prob, K);
        if (!rc)
            for (int64_t t = 0; t < nm; t++) {
                out[idx[t]] = got[t];
                memo_put(m, miss + t * W, key, got[t]);
            }
    }
    return rc;
}

static int q_fn(const qnet_t *q, int64_t task, const uint64_t *states, int64_t n, int64_t W, double *out,
                const int32_t *support, const double *prob, int64_t K) {
    (void)support; (void)prob; (void)K;
    return q_compute(q, task, states, n, W, out);
}

/* V_AP(s) = sum over the support of P(tau) q_max(s, tau), per state, tasks in support order. */
static int v_fn(const qnet_t *q, int64_t unused, const uint64_t *states, int64_t n, int64_t W, double *out,
                const int32_t *support, const double *prob, int64_t K) {
    (void)unused;
    double *tmp = malloc(sizeof(double) * (size_t)(n > 0 ? n : 1));
    if (!tmp) return -1;
    for (int64_t i = 0; i < n; i++) out[i] = 0.0;
    for (int64_t k = 0; k < K; k++) {
        if (q_compute(q, support[k], states, n, W, tmp)) { free(tmp); return -1; }
        for (int64_t i = 0; i < n; i++) out[i] = out[i] + tmp[i] * prob[k];
    }
    free(tmp);
    return 0;
}

/* The search's bn_native_fn (planning/search/_bn.c): max_a Q(s, task, a) per state. */
int qnet_q_max(void *ctx, int64_t task, const uint64_t *states, int64_t n, int64_t W, double *out) {
    const qnet_t *q = (const qnet_t *)ctx;
    if (W != q->W || task < 0 || task >= q->n_tasks) return -1;
    return memoized(q, task, task, states, n, W, out, q_fn, NULL, NULL, 0);
}

/* V_AP under the task distribution `prob` over `support`; `key` (negative) names that distribution in the
   memo: -1 the layout's P, others one per distribution the caller has used (learning/q/inference.py). */
int qnet_v_ap(void *ctx, const uint64_t *states, int64_t n, int64_t W, const int32_t *support, const double *prob,
              int64_t K, int64_t key, double *out) {
    const qnet_t *q = (const qnet_t *)ctx;
    if (W != q->W || key >= 0) return -1;
    for (int64_t k = 0; k < K; k++) if (support[k] < 0 || support[k] >= q->n_tasks) return -1;
    return memoized(q, key, 0, states, n, W, out, v_fn, support, prob, K);
}
