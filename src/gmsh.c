/* gmsh.c: Gmsh MSH files (4.1 ASCII or binary, ASCII 2.2) read into a mesh with named node and
   facet sets, validated like a case file: every error names the file, the line (the byte in a
   binary file) and what was expected. */
#include "config.h"
#include <moreau/mesh.h>
#include "mesh_internal.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Longest token (Gmsh's names are at most 127 characters, within quotes). */
#define MSH_TOKEN_MAX 256
/* Bounds on the small tables: physical names, entities, physical tags per entity and in all. */
#define MSH_MAX_TABLE 1000000
/* The largest mesh file read (bytes). */
#define MO_MESH_FILE_MAX 1e9
#define MSH_MAX_PHYS_PER_ENTITY 1024
/* An element is degenerate when its measure over its longest edge to the power dim, or the sine
   of its sharpest corner (2D: cross product of the two edges at the corner over their lengths;
   3D: triple product of the three edges over their lengths), is at most MSH_MIN_SINE, or when two
   of its nodes are closer than MSH_COINCIDE times the mesh's mean edge; inverted when a corner's
   sine is below -MSH_MIN_SINE (doc/case-format.md, "Gmsh files"). */
#define MSH_MIN_SINE 1e-6
#define MSH_COINCIDE 1e-10

/* The element types moreau reads; any other is refused with its Gmsh name. The 3-node line is
   the side of a T6 body only. perm: moreau's node a is the file's node perm[a] (Gmsh numbers the
   10-node tetrahedron's middles of edges 23 and 13 as its 9th and 10th nodes, VTK and moreau the
   other way round, mesh.h). */
enum { G_POINT = 0, G_LINE, G_TRI, G_QUAD, G_HEX, G_TET, G_TET10, G_TRI6, G_LINE3, G_NTYPES };
static const struct {
  int gmsh, dim, nen, nvert;
  const char *name, *names;
  mo_eltype mo;
  int perm[MO_NEN_MAX];
} gtype[G_NTYPES] = {
  {15, 0, 1, 1, "point", "points", MO_EL_NTYPES, {0}},
  {1, 1, 2, 2, "line", "lines", MO_EL_BAR2, {0, 1}},
  {2, 2, 3, 3, "triangle", "triangles", MO_EL_T3, {0, 1, 2}},
  {3, 2, 4, 4, "quadrangle", "quadrangles", MO_EL_Q4, {0, 1, 2, 3}},
  {5, 3, 8, 8, "hexahedron", "hexahedra", MO_EL_H8, {0, 1, 2, 3, 4, 5, 6, 7}},
  {4, 3, 4, 4, "tetrahedron", "tetrahedra", MO_EL_T4, {0, 1, 2, 3}},
  {11, 3, 10, 4, "10-node tetrahedron", "10-node tetrahedra", MO_EL_T10, {0, 1, 2, 3, 4, 5, 6, 7, 9, 8}},
  {9, 2, 6, 3, "6-node triangle", "6-node triangles", MO_EL_T6, {0, 1, 2, 3, 4, 5}},
  {8, 1, 3, 2, "3-node line", "3-node lines", MO_EL_NTYPES, {0, 1, 2}},
};

static const char *gmsh_type_name(long long t)
{
  switch (t) {
  case 4: return "4-node tetrahedron";
  case 6: return "6-node prism";
  case 7: return "5-node pyramid";
  case 8: return "3-node line";
  case 9: return "6-node triangle";
  case 10: return "9-node quadrangle";
  case 11: return "10-node tetrahedron";
  case 12: return "27-node hexahedron";
  case 16: return "8-node quadrangle";
  case 17: return "20-node hexahedron";
  default: return NULL;
  }
}

static const char *dim_word(int dim)
{
  static const char *w[4] = {"point", "curve", "surface", "volume"};
  return dim >= 0 && dim < 4 ? w[dim] : "entity";
}

typedef struct {
  int dim, tag;
  int phys0, nphys; /* slice of the physical-tag pool */
  long line;
} msh_entity;

typedef struct {
  int dim, tag;
  char *name;
  long line;
} msh_pname;

typedef struct {
  long long tag;
  size_t idx;
} msh_tagidx;

/* The reader: the stream, the current token, and everything read so far. */
typedef struct {
  FILE *f;
  const char *file;
  long line, at;         /* line of the current token; line the stream is on */
  int nl_last;           /* the last byte read was a newline */
  char tok[MSH_TOKEN_MAX];
  char shown[64];        /* the token as printed in messages */
  long pos;              /* bytes read so far */
  int term;              /* the byte that ended the last token */
  int binary, inbin;     /* a binary file (4.1); its binary section under way ($Entities, $Nodes, $Elements) */
  int swap, dsize;       /* binary: the file's byte order is not this machine's; bytes of its size_t */
  char posbuf[4][32];    /* positions formatted for messages (W) */
  int nat;
  mo_ctx *ctx;
  long long max_nodes, max_elems;
  int version;           /* 41 or 22 */
  long sec_line[5];      /* where $MeshFormat, $PhysicalNames, $Entities, $Nodes, $Elements begin */
  /* $PhysicalNames */
  msh_pname *pn;
  size_t npn, cappn;
  /* $Entities (4.1) */
  msh_entity *ent;
  size_t nent, capent;
  int *ptag;
  size_t nptag, capptag;
  /* $Nodes */
  long long *ntag;
  double *nx;            /* 3 per node */
  long *nline;
  size_t nnode, capnode;
  long long nmin, nmax;  /* tag range announced (4.1) */
  /* $Elements: node tags in enode[eoff[e] ..], then file node indices once mapped */
  unsigned char *etype;
  int *egrp;             /* 4.1: entity tag; 2.2: physical tag (0: none) */
  long long *etag;
  long *eline;
  size_t *eoff;
  size_t nel, capel;
  long long *enode;
  size_t nenode, capenode;
} msh;

enum { S_FORMAT = 0, S_NAMES, S_ENTITIES, S_NODES, S_ELEMENTS };

static void msh_release(msh *R)
{
  size_t i;
  for (i = 0; i < R->npn; i++) mo_free(R->pn[i].name);
  mo_free(R->pn);
  mo_free(R->ent);
  mo_free(R->ptag);
  mo_free(R->ntag);
  mo_free(R->nx);
  mo_free(R->nline);
  mo_free(R->etype);
  mo_free(R->egrp);
  mo_free(R->etag);
  mo_free(R->eline);
  mo_free(R->eoff);
  mo_free(R->enode);
}

/* --- messages ------------------------------------------------------------------------------ */

/* Positions are lines (> 0), bytes of a binary file (-1 - offset), or 0 for the file as a whole. */
static int msh_verror(msh *R, int code, long line, const char *fmt, va_list ap)
{
  char msg[1024];
  vsnprintf(msg, sizeof msg, fmt, ap);
  if (line > 0) return mo_error(R->ctx, code, "%s:%ld: %s", R->file, line, msg);
  if (line < 0) return mo_error(R->ctx, code, "%s: byte %ld: %s", R->file, -1 - line, msg);
  return mo_error(R->ctx, code, "%s: %s", R->file, msg);
}

/* How a position reads in messages ("line 12", "byte 4711"). */
static const char *where(long line, char *buf, size_t n)
{
  if (line < 0) snprintf(buf, n, "byte %ld", -1 - line);
  else snprintf(buf, n, "line %ld", line);
  return buf;
}

/* The same in the reader's own buffers (four at a time, for one message). */
static const char *W(msh *R, long line)
{
  char *b = R->posbuf[R->nat++ & 3];
  return where(line, b, sizeof R->posbuf[0]);
}

/* An error of kind `code` at `line` (0: the file as a whole). */
static int msh_error(msh *R, int code, long line, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static int msh_error(msh *R, int code, long line, const char *fmt, ...)
{
  va_list ap;
  int st;
  va_start(ap, fmt);
  st = msh_verror(R, code, line, fmt, ap);
  va_end(ap);
  return st;
}

/* An input error at the current token. */
static int msh_bad(msh *R, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int msh_bad(msh *R, const char *fmt, ...)
{
  va_list ap;
  int st;
  va_start(ap, fmt);
  st = msh_verror(R, MO_EINPUT, R->line, fmt, ap);
  va_end(ap);
  return st;
}

/* The current token for messages: printable bytes only, at most 40 of them. */
static const char *shown(msh *R)
{
  size_t i, n = 0;
  for (i = 0; R->tok[i] && n < 40; i++) {
    unsigned char c = (unsigned char)R->tok[i];
    R->shown[n++] = c >= 32 && c < 127 ? (char)c : '?';
  }
  if (R->tok[i]) {
    memcpy(R->shown + n, "...", 3);
    n += 3;
  }
  R->shown[n] = '\0';
  return R->shown;
}

/* --- tokens -------------------------------------------------------------------------------- */

static int is_blank(int c)
{
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}

/* Next token: a run of non-blank bytes, or a quoted string (quotes kept) closed on its line.
   1: a token in R->tok at line R->line; 0: end of file; -1: an error is recorded. */
static int msh_next(msh *R)
{
  int c, n = 0;
  for (;;) {
    c = getc_unlocked(R->f);
    if (c == EOF) {
      R->line = R->at > 1 && R->nl_last ? R->at - 1 : R->at; /* the last line, not the one after */
      if (R->binary) R->line = -1 - R->pos;
      if (ferror(R->f)) {
        msh_error(R, MO_EIO, R->at, "read error (%s)", strerror(errno));
        return -1;
      }
      return 0;
    }
    R->pos++;
    R->nl_last = c == '\n';
    if (c == '\n' && !(++R->at & 0xffff) && R->ctx->interrupt && *R->ctx->interrupt) {
      mo_error(R->ctx, MO_EINTERRUPT, "%s: interrupted while reading line %ld", R->file, R->at);
      return -1;
    }
    else if (!is_blank(c)) break;
  }
  R->line = R->binary ? -R->pos : R->at; /* the token's first byte: offset pos - 1 */
  if (c == '"') {
    R->tok[n++] = '"';
    do {
      c = getc_unlocked(R->f);
      R->pos += c != EOF;
      if (c == EOF || c == '\n' || c == '\0') {
        R->tok[n] = '\0';
        msh_bad(R, "a quoted name is not closed on its line");
        return -1;
      }
      if (n >= MSH_TOKEN_MAX - 1) {
        R->tok[n] = '\0';
        msh_bad(R, "a quoted name longer than %d characters", MSH_TOKEN_MAX - 3);
        return -1;
      }
      R->tok[n++] = (char)c;
    } while (c != '"');
  } else {
    do {
      if (c == '\0') {
        R->tok[n] = '\0';
        msh_bad(R, "a NUL byte: is this a binary file?");
        return -1;
      }
      if (n >= MSH_TOKEN_MAX - 1) {
        R->tok[n] = '\0';
        msh_bad(R, "a word longer than %d characters", MSH_TOKEN_MAX - 1);
        return -1;
      }
      R->tok[n++] = (char)c;
      c = getc_unlocked(R->f);
      R->pos += c != EOF;
    } while (c != EOF && !is_blank(c));
    R->nl_last = c == '\n';
    R->term = c;
    if (c == '\n') R->at++;
  }
  R->tok[n] = '\0';
  return 1;
}

/* --- binary values (MSH 4.1 binary: int 4 bytes, size_t dsize bytes, double 8 bytes, in the
   file's byte order) -------------------------------------------------------------------------- */

/* n bytes of a binary section, in this machine's byte order; an error naming `what` when the file
   ends first. */
static int bin_read(msh *R, void *buf, size_t n, const char *what)
{
  unsigned char *b = buf;
  size_t got;
  R->line = -1 - R->pos;
  got = fread(buf, 1, n, R->f);
  R->pos += (long)got;
  if (got < n) {
    if (ferror(R->f)) return msh_error(R, MO_EIO, R->line, "read error (%s)", strerror(errno));
    return msh_bad(R, "the file ends inside a binary section (%zu of the %zu bytes of %s)", got, n, what);
  }
  if (R->swap)
    for (got = 0; got < n / 2; got++) {
      unsigned char t = b[got];
      b[got] = b[n - 1 - got];
      b[n - 1 - got] = t;
    }
  return MO_OK;
}

/* A binary integer of `bytes` bytes (4: a signed int; 4 or 8: an unsigned size_t) in [lo, hi]. */
static int bin_int(msh *R, int size_t_kind, const char *what, long long lo, long long hi, long long *v)
{
  int st;
  if (!size_t_kind) {
    int32_t i;
    if ((st = bin_read(R, &i, 4, what))) return st;
    *v = i;
  } else if (R->dsize == 4) {
    uint32_t u;
    if ((st = bin_read(R, &u, 4, what))) return st;
    *v = (long long)u;
  } else {
    uint64_t u;
    if ((st = bin_read(R, &u, 8, what))) return st;
    if (u > (uint64_t)LLONG_MAX)
      return msh_bad(R, "%s is %llu: it must lie in [%lld, %lld]", what, (unsigned long long)u, lo, hi);
    *v = (long long)u;
  }
  if (*v < lo || *v > hi) {
    if (hi == LLONG_MAX) return msh_bad(R, "%s is %lld: it must be at least %lld", what, *v, lo);
    return msh_bad(R, "%s is %lld: it must lie in [%lld, %lld]", what, *v, lo, hi);
  }
  return MO_OK;
}

/* A token that a value of kind `what` must be: not the end of the file, not a section mark. */
static int msh_value_token(msh *R, const char *what)
{
  int t = msh_next(R);
  if (t < 0) return R->ctx->status;
  if (t == 0) return msh_bad(R, "the file ends where %s was expected", what);
  if (R->tok[0] == '$')
    return msh_bad(R, "expected %s, found %s: the section ends before the count announced", what,
                   shown(R));
  return MO_OK;
}

/* An integer in [lo, hi]: text, or in a binary section a 4-byte int. */
static int msh_int(msh *R, const char *what, long long lo, long long hi, long long *v)
{
  char *end;
  int st;
  if (R->inbin) return bin_int(R, 0, what, lo, hi, v);
  st = msh_value_token(R, what);
  if (st) return st;
  errno = 0;
  *v = strtoll(R->tok, &end, 10);
  if (end == R->tok || *end) return msh_bad(R, "expected %s (an integer), found '%s'", what, shown(R));
  if (errno == ERANGE || *v < lo || *v > hi) {
    if (hi == LLONG_MAX) return msh_bad(R, "%s is %s: it must be at least %lld", what, shown(R), lo);
    return msh_bad(R, "%s is %s: it must lie in [%lld, %lld]", what, shown(R), lo, hi);
  }
  return MO_OK;
}

/* The same for a count or a tag the binary format writes as a size_t. */
static int msh_size(msh *R, const char *what, long long lo, long long hi, long long *v)
{
  int st;
  if (!R->inbin) return msh_int(R, what, lo, hi, v);
  st = bin_int(R, 1, what, lo, hi, v);
  return st;
}

static int msh_int32(msh *R, const char *what, long long lo, long long hi, int *v)
{
  long long w;
  int st = msh_int(R, what, lo, hi, &w);
  *v = st ? 0 : (int)w;
  return st;
}

/* A count of items, refused with MO_ELIMIT past `limit` (before anything is allocated). */
static int msh_count(msh *R, const char *what, long long limit, const char *why, long long *v)
{
  int st = msh_size(R, what, 0, LLONG_MAX, v);
  if (st) return st;
  if (*v > limit)
    return msh_error(R, MO_ELIMIT, R->line, "%s: %lld, more than the limit of %lld%s", what, *v,
                     limit, why);
  return MO_OK;
}

/* A finite number. */
static int msh_real(msh *R, const char *what, double *v)
{
  char *end;
  int st;
  if (R->inbin) {
    if ((st = bin_read(R, v, 8, what))) return st;
    if (!isfinite(*v)) return msh_bad(R, "%s is %g, not a finite number", what, *v);
    return MO_OK;
  }
  st = msh_value_token(R, what);
  if (st) return st;
  *v = strtod(R->tok, &end);
  if (end == R->tok || *end) return msh_bad(R, "expected %s (a number), found '%s'", what, shown(R));
  if (!isfinite(*v)) return msh_bad(R, "%s is '%s', not a finite number", what, shown(R));
  return MO_OK;
}

/* The end mark of the section that began at `line`. */
static int msh_end(msh *R, const char *mark, long line)
{
  int t;
  if (R->inbin) {
    /* after binary data: a newline, then the mark (binary bytes are no tokens) */
    size_t k = 0, n = strlen(mark);
    int c;
    while ((c = getc_unlocked(R->f)) == '\n' || c == '\r') R->pos++;
    R->line = -1 - R->pos;
    while (c != EOF && k < n && c == mark[k]) {
      R->pos++;
      k++;
      c = k < n ? getc_unlocked(R->f) : c;
    }
    if (k == n) return MO_OK;
    if (c == EOF && !ferror(R->f))
      return msh_bad(R, "the file ends inside the section that begins at %s: expected %s", W(R, line), mark);
    return msh_bad(R, "expected %s after the binary data: the section holds more, or other, bytes than its counts "
                   "announce", mark);
  }
  t = msh_next(R);
  if (t < 0) return R->ctx->status;
  if (t == 0)
    return msh_bad(R, "the file ends inside the section that begins at %s: expected %s", W(R, line),
                   mark);
  if (strcmp(R->tok, mark)) {
    if (R->tok[0] == '$') return msh_bad(R, "expected %s, found %s", mark, shown(R));
    return msh_bad(R, "expected %s, found '%s': the section holds more than its counts announce",
                   mark, shown(R));
  }
  return MO_OK;
}

/* The block p (capacity *cap items of `size` bytes) with room for `need` items: p itself when it
   has room, else p grown by doubling; NULL when the allocation fails (p stays valid and owned by
   the caller). The arrays grow with what the file holds, never with what it announces. */
static void *msh_grow(mo_ctx *ctx, void *p, size_t *cap, size_t need, size_t size)
{
  size_t c = *cap ? *cap : 64;
  void *q;
  if (p && need <= *cap) return p;
  while (c < need) c *= 2;
  if (!(q = mo_realloc(ctx, p, c * size))) return NULL;
  *cap = c;
  return q;
}

/* --- sections ------------------------------------------------------------------------------- */

static int read_format(msh *R)
{
  long long ft, ds;
  double v;
  char *end;
  int st = msh_value_token(R, "the format version");
  if (st) return st;
  v = strtod(R->tok, &end);
  if (end == R->tok || *end) return msh_bad(R, "expected the format version (4.1 or 2.2), found '%s'", shown(R));
  if (v == 4.1) R->version = 41;
  else if (v >= 2 && v < 3) R->version = 22;
  else if (v == 4.0)
    return msh_bad(R, "MSH 4.0 is not read: save the mesh as MSH 4.1 (Gmsh's default) or 2.2");
  else
    return msh_bad(R, "MSH version %s is not read: save the mesh as MSH 4.1 or 2.2", shown(R));
  if ((st = msh_int(R, "the file type (0 for ASCII, 1 for binary)", 0, 1, &ft))) return st;
  if (ft == 1 && R->version == 22)
    return msh_bad(R, "a binary MSH 2.2 file is not read: save it as MSH 4.1 (binary or ASCII) or as ASCII 2.2");
  if ((st = msh_int(R, "the data size", 1, 64, &ds))) return st;
  if (ft == 1) {
    /* binary 4.1: the size of its size_t, then the integer 1 in the writer's byte order */
    unsigned char one[4];
    int c;
    if (ds != 4 && ds != 8)
      return msh_bad(R, "a binary file of data size %lld: Gmsh writes size_t of 4 or 8 bytes", ds);
    if (R->term == '\r' && (c = getc_unlocked(R->f)) != '\n') ungetc(c, R->f);
    else if (R->term == '\r') R->pos++;
    R->binary = 1;
    R->dsize = (int)ds;
    R->line = -1 - R->pos;
    if (fread(one, 1, 4, R->f) != 4) return msh_bad(R, "the file ends where the binary check integer 1 was expected");
    R->pos += 4;
    {
      uint32_t w; /* 1 as this machine reads it: the file's byte order is ours; 2^24: the other one */
      memcpy(&w, one, 4);
      if (w == 1) R->swap = 0;
      else if (w == (uint32_t)1 << 24) R->swap = 1;
      else return msh_bad(R, "the binary check integer reads %02x %02x %02x %02x, not 1 in either byte order: "
                          "a damaged file, or one transferred as text", one[0], one[1], one[2], one[3]);
    }
  }
  return msh_end(R, "$EndMeshFormat", R->sec_line[S_FORMAT]);
}

static int read_names(msh *R)
{
  long long n, i;
  void *gp;
  int st;
  if ((st = msh_count(R, "the number of physical names", MSH_MAX_TABLE, "", &n))) return st;
  for (i = 0; i < n; i++) {
    msh_pname *P;
    size_t len;
    const char *s;
    int dim, tag;
    if ((st = msh_int32(R, "the dimension of a physical group", 0, 3, &dim))) return st;
    if ((st = msh_int32(R, "the tag of a physical group", 1, INT_MAX, &tag))) return st;
    if ((st = msh_value_token(R, "the name of a physical group"))) return st;
    len = strlen(R->tok);
    if (R->tok[0] != '"' || len < 2)
      return msh_bad(R, "expected the name of physical %s %d (a quoted string), found '%s'",
                     dim_word(dim), tag, shown(R));
    if (len == 2) return msh_bad(R, "physical %s %d has an empty name", dim_word(dim), tag);
    if (len - 2 > 127)
      return msh_bad(R, "the name of physical %s %d is longer than 127 characters", dim_word(dim), tag);
    R->tok[len - 1] = '\0';
    s = R->tok + 1;
    if (strchr(s, '&'))
      return msh_bad(R, "physical name '%s' contains '&', which set names use for intersections", s);
    for (len = 0; s[len]; len++)
      if ((unsigned char)s[len] < 32)
        return msh_bad(R, "the name of physical %s %d holds a control character", dim_word(dim), tag);
    if (!(gp = msh_grow(R->ctx, R->pn, &R->cappn, R->npn + 1, sizeof *R->pn))) return MO_ENOMEM;
    R->pn = gp;
    P = &R->pn[R->npn];
    P->dim = dim;
    P->tag = tag;
    P->line = R->line;
    if (!(P->name = mo_strdup(R->ctx, s))) return MO_ENOMEM;
    R->npn++;
  }
  return msh_end(R, "$EndPhysicalNames", R->sec_line[S_NAMES]);
}

static int read_entities(msh *R)
{
  static const char *what_count[4] = {"the number of point entities", "the number of curve entities",
                                      "the number of surface entities", "the number of volume entities"};
  long long cnt[4], k, j, nb;
  void *gp;
  int d, st, c;
  double x;
  for (d = 0; d < 4; d++)
    if ((st = msh_count(R, what_count[d], MSH_MAX_TABLE, "", &cnt[d]))) return st;
  for (d = 0; d < 4; d++)
    for (k = 0; k < cnt[d]; k++) {
      msh_entity *E;
      long long np;
      if (!(gp = msh_grow(R->ctx, R->ent, &R->capent, R->nent + 1, sizeof *R->ent))) return MO_ENOMEM;
      R->ent = gp;
      E = &R->ent[R->nent];
      E->dim = d;
      if ((st = msh_int32(R, "an entity tag", 1, INT_MAX, &E->tag))) return st;
      E->line = R->line;
      for (c = 0; c < (d == 0 ? 3 : 6); c++)
        if ((st = msh_real(R, d == 0 ? "a point coordinate" : "a bounding box coordinate", &x))) return st;
      if ((st = msh_count(R, "the number of physical tags of an entity", MSH_MAX_PHYS_PER_ENTITY, "", &np)))
        return st;
      if (R->nptag + (size_t)np > MSH_MAX_TABLE)
        return msh_error(R, MO_ELIMIT, R->line, "more than %d physical tags on entities", MSH_MAX_TABLE);
      if (!(gp = msh_grow(R->ctx, R->ptag, &R->capptag, R->nptag + (size_t)np, sizeof *R->ptag)))
        return MO_ENOMEM;
      R->ptag = gp;
      E->phys0 = (int)R->nptag;
      E->nphys = (int)np;
      for (j = 0; j < np; j++) {
        int p;
        if ((st = msh_int32(R, "a physical tag", -INT_MAX, INT_MAX, &p))) return st;
        if (p == 0) return msh_bad(R, "physical tag 0 does not exist (tags start at 1)");
        R->ptag[R->nptag++] = p < 0 ? -p : p; /* a sign only orients the group in Gmsh */
      }
      R->nent++;
      if (d == 0) continue;
      if ((st = msh_count(R, "the number of bounding entities", MSH_MAX_TABLE, "", &nb))) return st;
      for (j = 0; j < nb; j++) {
        int b;
        if ((st = msh_int32(R, "a bounding entity tag", -INT_MAX, INT_MAX, &b))) return st;
      }
    }
  return msh_end(R, "$EndEntities", R->sec_line[S_ENTITIES]);
}

static int push_node(msh *R, long long tag, long line)
{
  size_t cap = R->capnode;
  void *gp;
  if (!(gp = msh_grow(R->ctx, R->ntag, &cap, R->nnode + 1, sizeof *R->ntag))) return MO_ENOMEM;
  R->ntag = gp;
  if (cap != R->capnode) { /* the three arrays share one capacity */
    if (!(gp = mo_realloc(R->ctx, R->nx, cap * 3 * sizeof *R->nx))) return MO_ENOMEM;
    R->nx = gp;
    if (!(gp = mo_realloc(R->ctx, R->nline, cap * sizeof *R->nline))) return MO_ENOMEM;
    R->nline = gp;
    R->capnode = cap;
  }
  R->ntag[R->nnode] = tag;
  R->nline[R->nnode] = line;
  R->nnode++;
  return MO_OK;
}

static int read_coords(msh *R, size_t i)
{
  static const char *what[3] = {"the x coordinate of a node", "the y coordinate of a node",
                                "the z coordinate of a node"};
  int c, st;
  for (c = 0; c < 3; c++)
    if ((st = msh_real(R, what[c], &R->nx[3 * i + (size_t)c]))) return st;
  return MO_OK;
}

static const char node_limit_why[] =
    " (at least one dof per node, and the context's max_dofs bounds the dofs: a direct "
    "factorization would not fit in memory)";

static int read_nodes(msh *R)
{
  long long nblock, total, b, i, left;
  long head;
  int st;
  if (R->version == 22) {
    if ((st = msh_count(R, "the number of nodes", R->max_nodes, node_limit_why, &total))) return st;
    for (i = 0; i < total; i++) {
      long long tag;
      if ((st = msh_int(R, "a node tag", 1, LLONG_MAX, &tag))) return st;
      if ((st = push_node(R, tag, R->line))) return st;
      if ((st = read_coords(R, R->nnode - 1))) return st;
    }
    return msh_end(R, "$EndNodes", R->sec_line[S_NODES]);
  }
  if ((st = msh_count(R, "the number of node blocks", LLONG_MAX, "", &nblock))) return st;
  head = R->line;
  if ((st = msh_count(R, "the number of nodes", R->max_nodes, node_limit_why, &total))) return st;
  if ((st = msh_size(R, "the smallest node tag", 0, LLONG_MAX, &R->nmin))) return st;
  if ((st = msh_size(R, "the largest node tag", 0, LLONG_MAX, &R->nmax))) return st;
  left = total;
  for (b = 0; b < nblock; b++) {
    long long edim, etag, param, nb, extra;
    size_t first = R->nnode;
    if ((st = msh_int(R, "the dimension of a node block's entity", 0, 3, &edim))) return st;
    if ((st = msh_int(R, "the entity tag of a node block", 1, INT_MAX, &etag))) return st;
    if ((st = msh_int(R, "the parametric flag of a node block (0 or 1)", 0, 1, &param))) return st;
    if ((st = msh_size(R, "the number of nodes in a block", 0, LLONG_MAX, &nb))) return st;
    if (nb > left)
      return msh_bad(R, "a block of %lld nodes, but only %lld of the %lld announced at %s remain",
                     nb, left, total, W(R, head));
    for (i = 0; i < nb; i++) {
      long long tag;
      if ((st = msh_size(R, "a node tag", 1, LLONG_MAX, &tag))) return st;
      if (tag < R->nmin || tag > R->nmax)
        return msh_bad(R, "node tag %lld lies outside the range [%lld, %lld] announced at %s", tag,
                       R->nmin, R->nmax, W(R, head));
      if ((st = push_node(R, tag, R->line))) return st;
    }
    extra = param ? edim : 0; /* parametric coordinates u (curves), u v (surfaces), u v w */
    for (i = 0; i < nb; i++) {
      long long k;
      double u;
      if ((st = read_coords(R, first + (size_t)i))) return st;
      R->nline[first + (size_t)i] = R->line;
      for (k = 0; k < extra; k++)
        if ((st = msh_real(R, "a parametric coordinate of a node", &u))) return st;
    }
    left -= nb;
  }
  if (left)
    return msh_bad(R, "the node blocks hold %lld nodes, but %s announces %lld", total - left,
                   W(R, head), total);
  return msh_end(R, "$EndNodes", R->sec_line[S_NODES]);
}

static int type_of(msh *R, long long t, int *g)
{
  const char *n;
  int k;
  for (k = 0; k < G_NTYPES; k++)
    if (gtype[k].gmsh == t) {
      *g = k;
      return MO_OK;
    }
  n = gmsh_type_name(t);
  return msh_bad(R, "element type %lld%s%s%s is not supported: moreau reads 2-node lines, 3- and 6-node "
                 "triangles, 4-node quadrangles, 4- and 10-node tetrahedra, 8-node hexahedra, and 3-node lines "
                 "as the sides of 6-node triangles (Mesh.ElementOrder = 1 or 2 with Mesh.SecondOrderIncomplete = 0; "
                 "no prisms or pyramids)", t, n ? " (" : "", n ? n : "", n ? ")" : "");
}

static int push_element(msh *R, int g, int grp, long long tag, long line)
{
  size_t cap = R->capel;
  void *gp;
  if (R->nel + 1 > cap) { /* the five arrays share one capacity */
    void *p;
    cap = cap ? 2 * cap : 64;
    if (!(p = mo_realloc(R->ctx, R->etype, cap * sizeof *R->etype))) return MO_ENOMEM;
    R->etype = p;
    if (!(p = mo_realloc(R->ctx, R->egrp, cap * sizeof *R->egrp))) return MO_ENOMEM;
    R->egrp = p;
    if (!(p = mo_realloc(R->ctx, R->etag, cap * sizeof *R->etag))) return MO_ENOMEM;
    R->etag = p;
    if (!(p = mo_realloc(R->ctx, R->eline, cap * sizeof *R->eline))) return MO_ENOMEM;
    R->eline = p;
    if (!(p = mo_realloc(R->ctx, R->eoff, cap * sizeof *R->eoff))) return MO_ENOMEM;
    R->eoff = p;
    R->capel = cap;
  }
  if (!(gp = msh_grow(R->ctx, R->enode, &R->capenode, R->nenode + (size_t)gtype[g].nen, sizeof *R->enode)))
    return MO_ENOMEM;
  R->enode = gp;
  R->etype[R->nel] = (unsigned char)g;
  R->egrp[R->nel] = grp;
  R->etag[R->nel] = tag;
  R->eline[R->nel] = line;
  R->eoff[R->nel] = R->nenode;
  R->nel++;
  return MO_OK;
}

/* The element's node tags, stored in moreau's order (gtype[g].perm). */
static int read_element_nodes(msh *R, int g)
{
  long long tag[MO_NEN_MAX];
  int a, st;
  for (a = 0; a < gtype[g].nen; a++)
    if ((st = msh_size(R, "a node tag of an element", 1, LLONG_MAX, &tag[a]))) return st;
  for (a = 0; a < gtype[g].nen; a++) R->enode[R->nenode++] = tag[gtype[g].perm[a]];
  return MO_OK;
}

static const char elem_limit_why[] =
    " (twice the context's max_dofs: the mesh would not fit a direct factorization)";

static int read_elements(msh *R)
{
  long long nblock, total, b, i, left, lo, hi;
  long head;
  int st, g;
  if (R->version == 22) {
    if ((st = msh_count(R, "the number of elements", R->max_elems, elem_limit_why, &total))) return st;
    for (i = 0; i < total; i++) {
      long long tag, type, ntags, k, t;
      long line;
      int phys = 0;
      if ((st = msh_int(R, "an element tag", 1, LLONG_MAX, &tag))) return st;
      line = R->line;
      if ((st = msh_int(R, "an element type", 1, INT_MAX, &type))) return st;
      if ((st = type_of(R, type, &g))) return st;
      if ((st = msh_int(R, "the number of tags of an element", 0, 1000, &ntags))) return st;
      for (k = 0; k < ntags; k++) {
        if ((st = msh_int(R, k == 0 ? "the physical tag of an element" : "a tag of an element",
                          k == 0 ? 0 : -INT_MAX, INT_MAX, &t)))
          return st;
        if (k == 0) phys = (int)t;
      }
      if ((st = push_element(R, g, phys, tag, line))) return st;
      if ((st = read_element_nodes(R, g))) return st;
    }
    return msh_end(R, "$EndElements", R->sec_line[S_ELEMENTS]);
  }
  if ((st = msh_count(R, "the number of element blocks", LLONG_MAX, "", &nblock))) return st;
  head = R->line;
  if ((st = msh_count(R, "the number of elements", R->max_elems, elem_limit_why, &total))) return st;
  if ((st = msh_size(R, "the smallest element tag", 0, LLONG_MAX, &lo))) return st;
  if ((st = msh_size(R, "the largest element tag", 0, LLONG_MAX, &hi))) return st;
  left = total;
  for (b = 0; b < nblock; b++) {
    long long edim, etag, type, nb;
    if ((st = msh_int(R, "the dimension of an element block's entity", 0, 3, &edim))) return st;
    if ((st = msh_int(R, "the entity tag of an element block", 1, INT_MAX, &etag))) return st;
    if ((st = msh_int(R, "the element type of a block", 1, INT_MAX, &type))) return st;
    if ((st = type_of(R, type, &g))) return st;
    if (gtype[g].dim != edim)
      return msh_bad(R, "a block of %s (dimension %d) on a %s (dimension %lld)", gtype[g].names,
                     gtype[g].dim, dim_word((int)edim), edim);
    if ((st = msh_size(R, "the number of elements in a block", 0, LLONG_MAX, &nb))) return st;
    if (nb > left)
      return msh_bad(R, "a block of %lld elements, but only %lld of the %lld announced at %s remain",
                     nb, left, total, W(R, head));
    for (i = 0; i < nb; i++) {
      long long tag;
      if ((st = msh_size(R, "an element tag", 1, LLONG_MAX, &tag))) return st;
      if (tag < lo || tag > hi)
        return msh_bad(R, "element tag %lld lies outside the range [%lld, %lld] announced at %s",
                       tag, lo, hi, W(R, head));
      if ((st = push_element(R, g, (int)etag, tag, R->line))) return st;
      if ((st = read_element_nodes(R, g))) return st;
    }
    left -= nb;
  }
  if (left)
    return msh_bad(R, "the element blocks hold %lld elements, but %s announces %lld",
                   total - left, W(R, head), total);
  return msh_end(R, "$EndElements", R->sec_line[S_ELEMENTS]);
}

/* A section moreau does not need ($Periodic, $NodeData, $Comments, ...): skipped to its end. In a
   binary file its bytes are searched for the end mark (binary data need not be tokens). */
static int skip_section(msh *R)
{
  char end[MSH_TOKEN_MAX + 8], name[64], at[32];
  long line = R->line;
  int t;
  snprintf(end, sizeof end, "$End%s", R->tok + 1);
  snprintf(name, sizeof name, "%s", shown(R));
  if (R->binary) {
    size_t k = 0, n = strlen(end);
    int c;
    while ((c = getc_unlocked(R->f)) != EOF) {
      R->pos++;
      k = c == end[k] ? k + 1 : c == end[0];
      if (k == n) {
        R->line = -1 - R->pos;
        return MO_OK;
      }
    }
    R->line = -1 - R->pos;
    return msh_bad(R, "the file ends inside section %s (%s): no $End%s", name, where(line, at, sizeof at), name + 1);
  }
  for (;;) {
    t = msh_next(R);
    if (t < 0) return R->ctx->status;
    if (t == 0) return msh_bad(R, "the file ends inside section %s (%s): no $End%s", name, where(line, at, sizeof at), name + 1);
    if (!strcmp(R->tok, end)) return MO_OK;
  }
}

static int read_sections(msh *R)
{
  static const char *known[5] = {"$MeshFormat", "$PhysicalNames", "$Entities", "$Nodes", "$Elements"};
  int t, st, k;
  t = msh_next(R);
  if (t < 0) return R->ctx->status;
  if (t == 0) return msh_error(R, MO_EINPUT, 0, "the file is empty: expected $MeshFormat");
  if (strcmp(R->tok, "$MeshFormat"))
    return msh_bad(R, "not a Gmsh MSH file: expected $MeshFormat, found '%s'", shown(R));
  R->sec_line[S_FORMAT] = R->line;
  if ((st = read_format(R))) return st;
  for (;;) {
    t = msh_next(R);
    if (t < 0) return R->ctx->status;
    if (t == 0) break;
    if (R->tok[0] != '$' || !strncmp(R->tok, "$End", 4))
      return msh_bad(R, "expected a section ($Nodes, $Elements, ...), found '%s'", shown(R));
    for (k = 0; k < 5 && strcmp(R->tok, known[k]); k++) {}
    if (k == 5) {
      if (!strcmp(R->tok, "$PartitionedEntities"))
        return msh_bad(R, "a partitioned mesh is not read: save it without partitions");
      if ((st = skip_section(R))) return st;
      continue;
    }
    if (R->sec_line[k])
      return msh_bad(R, "a second %s section (the first begins at %s)", known[k], W(R, R->sec_line[k]));
    if (k == S_ENTITIES && R->version == 22)
      return msh_bad(R, "an $Entities section in an MSH 2.2 file");
    R->sec_line[k] = R->line;
    R->inbin = R->binary && k != S_NAMES; /* $PhysicalNames is text in binary files too */
    switch (k) {
    case S_NAMES: st = read_names(R); break;
    case S_ENTITIES: st = read_entities(R); break;
    case S_NODES: st = read_nodes(R); break;
    case S_ELEMENTS: st = read_elements(R); break;
    default: st = MO_EINTERNAL; break;
    }
    R->inbin = 0;
    if (st) return st;
  }
  if (!R->sec_line[S_NODES]) return msh_error(R, MO_EINPUT, 0, "no $Nodes section");
  if (!R->sec_line[S_ELEMENTS]) return msh_error(R, MO_EINPUT, 0, "no $Elements section");
  return MO_OK;
}

/* --- from the file's tables to a mesh ------------------------------------------------------- */

static int cmp_tagidx(const void *a, const void *b)
{
  const msh_tagidx *p = a, *q = b;
  if (p->tag != q->tag) return (p->tag > q->tag) - (p->tag < q->tag);
  return (p->idx > q->idx) - (p->idx < q->idx);
}

static int cmp_entity(const void *a, const void *b)
{
  const msh_entity *p = a, *q = b;
  if (p->dim != q->dim) return (p->dim > q->dim) - (p->dim < q->dim);
  if (p->tag != q->tag) return (p->tag > q->tag) - (p->tag < q->tag);
  return (p->line > q->line) - (p->line < q->line);
}

static int cmp_pname(const void *a, const void *b)
{
  const msh_pname *p = a, *q = b;
  if (p->dim != q->dim) return (p->dim > q->dim) - (p->dim < q->dim);
  if (p->tag != q->tag) return (p->tag > q->tag) - (p->tag < q->tag);
  return (p->line > q->line) - (p->line < q->line);
}

/* Physical names in order of dimension and name (the same name twice in one dimension). */
static int cmp_pname_name(const void *a, const void *b)
{
  const msh_pname *p = *(const msh_pname *const *)a, *q = *(const msh_pname *const *)b;
  int c = strcmp(p->name, q->name);
  if (p->dim != q->dim) return (p->dim > q->dim) - (p->dim < q->dim);
  return c ? c : (p->line > q->line) - (p->line < q->line);
}

/* Element keys for finding repeated elements: sorted node numbers, then the element. */
typedef struct {
  int key[MO_NEN_MAX];
  int el;
} msh_elkey;

static int cmp_elkey(const void *a, const void *b)
{
  const msh_elkey *p = a, *q = b;
  int i;
  for (i = 0; i < MO_NEN_MAX; i++)
    if (p->key[i] != q->key[i]) return (p->key[i] > q->key[i]) - (p->key[i] < q->key[i]);
  return (p->el > q->el) - (p->el < q->el);
}

static int cmp_int1(const void *a, const void *b)
{
  int x = *(const int *)a, y = *(const int *)b;
  return (x > y) - (x < y);
}

/* Physical tags of element e: *n of them from p[]. */
static int element_physicals(msh *R, size_t e, const int **p, int *n)
{
  *p = NULL;
  *n = 0;
  if (R->version == 22) {
    if (R->egrp[e] > 0) {
      *p = &R->egrp[e];
      *n = 1;
    }
    return MO_OK;
  }
  if (!R->nent) return MO_OK;
  {
    msh_entity key, *E;
    key.dim = gtype[R->etype[e]].dim;
    key.tag = R->egrp[e];
    key.line = 0;
    /* entities are sorted by (dim, tag, line) and unique in (dim, tag): compare without line */
    {
      size_t lo = 0, hi = R->nent;
      E = NULL;
      while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        const msh_entity *M = &R->ent[mid];
        int c = M->dim != key.dim ? (M->dim > key.dim) - (M->dim < key.dim)
                                  : (M->tag > key.tag) - (M->tag < key.tag);
        if (c == 0) {
          E = &R->ent[mid];
          break;
        }
        if (c < 0) lo = mid + 1;
        else hi = mid;
      }
    }
    if (!E)
      return msh_error(R, MO_EINPUT, R->eline[e], "element %lld lies on %s %d, which $Entities (%s) "
                       "does not define", R->etag[e], dim_word(key.dim), key.tag, W(R, R->sec_line[S_ENTITIES]));
    *p = &R->ptag[E->phys0];
    *n = E->nphys;
  }
  return MO_OK;
}

/* Shape checks of element e (file nodes c[], coordinates X, nd dimensions) of type g: the sign
   of the Jacobian at the centre, and the sines of the corners. */
static double corner_sine(const double *X, int nd, const int *c, int g, int k)
{
  static const int h8nb[8][3] = {{1, 3, 4}, {2, 0, 5}, {3, 1, 6}, {0, 2, 7},
                                 {7, 5, 0}, {4, 6, 1}, {5, 7, 2}, {6, 4, 3}};
  /* a tetrahedron's corner k: its edges to the other three in an even order of the corners */
  static const int t4nb[4][3] = {{1, 2, 3}, {2, 0, 3}, {0, 1, 3}, {0, 2, 1}};
  double a[3], b[3], w[3], la, lb, lw;
  int d, n = gtype[g].nvert;
  const double *p = &X[(size_t)c[k] * (size_t)nd];
  if (g == G_LINE) return X[(size_t)c[1] * (size_t)nd] > X[(size_t)c[0] * (size_t)nd] ? 1 : -1;
  if (g == G_HEX || g == G_TET || g == G_TET10) {
    const int *nb = g == G_HEX ? h8nb[k] : t4nb[k];
    for (d = 0; d < 3; d++) {
      a[d] = X[(size_t)c[nb[0]] * 3 + (size_t)d] - p[d];
      b[d] = X[(size_t)c[nb[1]] * 3 + (size_t)d] - p[d];
      w[d] = X[(size_t)c[nb[2]] * 3 + (size_t)d] - p[d];
    }
    la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    lw = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    return (a[0] * (b[1] * w[2] - b[2] * w[1]) - a[1] * (b[0] * w[2] - b[2] * w[0]) +
            a[2] * (b[0] * w[1] - b[1] * w[0])) / (la * lb * lw);
  }
  for (d = 0; d < 2; d++) {
    a[d] = X[(size_t)c[(k + 1) % n] * 2 + (size_t)d] - p[d];
    b[d] = X[(size_t)c[(k + n - 1) % n] * 2 + (size_t)d] - p[d];
  }
  la = sqrt(a[0] * a[0] + a[1] * a[1]);
  lb = sqrt(b[0] * b[0] + b[1] * b[1]);
  return (a[0] * b[1] - a[1] * b[0]) / (la * lb);
}

static double centre_jacobian(const double *X, int nd, const int *c, int g)
{
  static const double hs[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                  {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
  double J[3][3] = {{0}};
  int a, d, r;
  switch (g) {
  case G_LINE: return X[(size_t)c[1]] - X[(size_t)c[0]];
  case G_TRI:
  case G_TRI6: { /* a curved T6: its corners' triangle (the map itself is checked after, (T196)) */
    const double *p = &X[(size_t)c[0] * 2], *q = &X[(size_t)c[1] * 2], *s = &X[(size_t)c[2] * 2];
    return (q[0] - p[0]) * (s[1] - p[1]) - (q[1] - p[1]) * (s[0] - p[0]);
  }
  case G_TET:
  case G_TET10:
    for (a = 0; a < 3; a++)
      for (d = 0; d < 3; d++) J[d][a] = X[(size_t)c[a + 1] * 3 + (size_t)d] - X[(size_t)c[0] * 3 + (size_t)d];
    return J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1]) -
           J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0]) +
           J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0]);
  case G_QUAD:
    for (a = 0; a < 4; a++)
      for (d = 0; d < 2; d++)
        for (r = 0; r < 2; r++) J[d][r] += 0.25 * hs[a][r] * X[(size_t)c[a] * 2 + (size_t)d];
    return J[0][0] * J[1][1] - J[0][1] * J[1][0];
  default:
    for (a = 0; a < 8; a++)
      for (d = 0; d < 3; d++)
        for (r = 0; r < 3; r++) J[d][r] += 0.125 * hs[a][r] * X[(size_t)c[a] * 3 + (size_t)d];
    return J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1]) -
           J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0]) +
           J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0]);
  }
}

/* Edges of the element types (local node pairs). */
static int element_edges(int g, const int (**E)[2])
{
  static const int line[1][2] = {{0, 1}};
  static const int tri[3][2] = {{0, 1}, {1, 2}, {2, 0}};
  static const int quad[4][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}};
  static const int hex[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                 {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  static const int tet[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
  switch (g) {
  case G_LINE: *E = line; return 1;
  case G_TRI:
  case G_TRI6: *E = tri; return 3; /* between corners */
  case G_QUAD: *E = quad; return 4;
  case G_TET:
  case G_TET10: *E = tet; return 6;
  default: *E = hex; return 12;
  }
}

static double dist(const double *X, int nd, int i, int j)
{
  double s = 0;
  int d;
  for (d = 0; d < nd; d++) {
    double t = X[(size_t)i * (size_t)nd + (size_t)d] - X[(size_t)j * (size_t)nd + (size_t)d];
    s += t * t;
  }
  return sqrt(s);
}

/* Orientation and shape of the body elements (doc/case-format.md, "Gmsh files"): an element
   with a negative Jacobian at its centre is mirrored (*nreor counts them); coincident nodes, flat
   elements and corners of sine at most MSH_MIN_SINE are refused. fileof[n] is the file index of
   mesh node n (for the tags in messages). */
static int check_shapes(msh *R, mo_mesh *m, const int *body, const int *fileof, int gb, int *nreor)
{
  /* |reference element| x J: the measure of the element (of its corners' simplex) */
  static const double refmeasure[G_NTYPES] = {0, 1, 0.5, 4, 8, 1.0 / 6, 1.0 / 6, 0.5, 0};
  const int D = m->dim;
  const int(*E)[2];
  int ne = element_edges(gb, &E), k, a;
  size_t i, nedge = 0;
  double hmean = 0;
  *nreor = 0;
  for (i = 0; i < (size_t)m->nelem; i++)
    for (k = 0; k < ne; k++) {
      const int *c = &m->conn[i * (size_t)m->nen];
      hmean += dist(m->x, D, c[E[k][0]], c[E[k][1]]);
      nedge++;
    }
  hmean /= (double)(nedge ? nedge : 1);
  for (i = 0; i < (size_t)m->nelem; i++) {
    int *c = &m->conn[i * (size_t)m->nen];
    size_t fe = (size_t)body[i];
    double J, hmax = 0, smin = HUGE_VAL, rel;
    int kmin = 0;
    for (k = 0; k < ne; k++) {
      double l = dist(m->x, D, c[E[k][0]], c[E[k][1]]);
      if (!(l > MSH_COINCIDE * hmean))
        return msh_error(R, MO_EINPUT, R->eline[fe], "%s %lld is degenerate: its nodes %lld and %lld "
                         "coincide (distance %.3g; the mesh's mean edge is %.3g)", gtype[gb].name,
                         R->etag[fe], R->ntag[fileof[c[E[k][0]]]], R->ntag[fileof[c[E[k][1]]]], l,
                         hmean);
      if (l > hmax) hmax = l;
    }
    J = centre_jacobian(m->x, D, c, gb);
    if (J < 0) { /* written clockwise (left-handed): mirror the reference element */
      int t;
      switch (gb) {
      case G_LINE: t = c[0]; c[0] = c[1]; c[1] = t; break;
      case G_TRI: t = c[1]; c[1] = c[2]; c[2] = t; break;
      case G_TRI6: /* corners 1, 2 and the middles of 01, 20 */
        t = c[1]; c[1] = c[2]; c[2] = t;
        t = c[3]; c[3] = c[5]; c[5] = t;
        break;
      case G_QUAD: t = c[1]; c[1] = c[3]; c[3] = t; break;
      case G_TET: t = c[1]; c[1] = c[2]; c[2] = t; break;
      case G_TET10: /* corners 1, 2, the middles of 01 and 20, of 13 and 23 */
        t = c[1]; c[1] = c[2]; c[2] = t;
        t = c[4]; c[4] = c[6]; c[6] = t;
        t = c[8]; c[8] = c[9]; c[9] = t;
        break;
      default:
        for (a = 0; a < 4; a++) { t = c[a]; c[a] = c[a + 4]; c[a + 4] = t; }
      }
      J = -J; /* the centre is fixed by the mirror */
      (*nreor)++;
    }
    rel = refmeasure[gb] * J / pow(hmax, D);
    if (!(rel > MSH_MIN_SINE))
      return msh_error(R, MO_EINPUT, R->eline[fe], "%s %lld is degenerate (flat): its %s is %.3g times "
                       "the %s of its longest edge, a valid element needs more than %g", gtype[gb].name,
                       R->etag[fe], D == 3 ? "volume" : "area", rel, D == 3 ? "cube" : "square",
                       MSH_MIN_SINE);
    for (k = 0; gb != G_LINE && k < gtype[gb].nvert; k++) {
      double s = corner_sine(m->x, D, c, gb, k);
      if (s < smin) {
        smin = s;
        kmin = k;
      }
    }
    if (gb != G_LINE && smin <= -MSH_MIN_SINE)
      return msh_error(R, MO_EINPUT, R->eline[fe], "%s %lld is inverted at its corner node %lld (the "
                       "corner's sine is %.3g): a non-convex or self-intersecting element",
                       gtype[gb].name, R->etag[fe], R->ntag[fileof[c[kmin]]], smin);
    if (gb != G_LINE && smin <= MSH_MIN_SINE)
      return msh_error(R, MO_EINPUT, R->eline[fe], "%s %lld is degenerate at its corner node %lld: the "
                       "corner's sine is %.3g (an angle of 0 or 180 degrees), a valid element needs "
                       "more than %g", gtype[gb].name, R->etag[fe], R->ntag[fileof[c[kmin]]], smin,
                       MSH_MIN_SINE);
    if (gtype[gb].nen > gtype[gb].nvert) {
      /* a curved element: its map must keep the orientation of its corners everywhere (T196) */
      int at;
      double jmin = mo_mesh_elem_min_jacobian(m, (int)i, &at) / J; /* both det J of the reference simplex */
      char node[48] = "at its centre";
      if (at >= 0) snprintf(node, sizeof node, "at its node %lld", R->ntag[fileof[c[at]]]);
      if (!(jmin > MSH_MIN_SINE))
        return msh_error(R, MO_EINPUT, R->eline[fe], "%s %lld is %s %s (the Jacobian of its curved map there "
                         "is %.3g times that of its corners' %s): a middle node lies too far from the middle "
                         "of its edge", gtype[gb].name, R->etag[fe], jmin < 0 ? "inverted" : "degenerate", node,
                         jmin, D == 3 ? "tetrahedron" : "triangle");
    }
  }
  return MO_OK;
}

/* The sense in which element e runs through its local facet f (1 node: the facet's number; 2:
   the edge's direction; 4: the turn from the lowest node). Two elements that share a facet run
   through it in opposite senses unless the mesh folds over itself there. */
static int facet_sense(const mo_mesh *m, const mo_eltype_info *T, int e, int f)
{
  int v[4] = {0, 0, 0, 0}, a, lo = 0, n = T->nfv; /* the facet's corners */
  for (a = 0; a < n; a++) {
    v[a] = m->conn[(size_t)e * (size_t)m->nen + (size_t)T->facet[f][a]];
    if (v[a] < v[lo]) lo = a;
  }
  return n == 1 ? f : n == 2 ? v[0] < v[1] : v[(lo + 1) % n] < v[(lo + n - 1) % n];
}

static int check_folds(msh *R, const mo_mesh *m, const int *body, const int *fileof, int gb)
{
  static const char *side_word[4] = {"", "end", "edge", "face"};
  const mo_eltype_info *T = mo_eltype_get(m->type);
  mo_facet *S;
  size_t n, i, j;
  int a, st = mo_mesh_all_facets(m, &S, &n, R->ctx);
  if (st) return st;
  for (i = 0; i < n && !st; i = j) {
    for (j = i + 1; j < n && !mo_facet_cmp_key(&S[i], &S[j]); j++) {}
    if (j - i == 1 ||
        (j - i == 2 && facet_sense(m, T, S[i].elem, S[i].lface) != facet_sense(m, T, S[i + 1].elem, S[i + 1].lface)))
      continue;
    {
      size_t p = (size_t)body[S[i].elem], q = (size_t)body[S[i + 1].elem];
      char nodes[160];
      int k = 0;
      for (a = 0; a < T->nfv; a++) /* the key: its corners */
        k += snprintf(nodes + k, sizeof nodes - (size_t)k, "%s%lld", a ? ", " : "",
                      R->ntag[fileof[S[i].key[a]]]);
      if (j - i > 2)
        st = msh_error(R, MO_EINPUT, R->eline[q], "%zu elements share the %s of nodes %s (%s %lld here, "
                       "%s %lld at %s): the mesh overlaps itself there", j - i,
                       side_word[T->dim], nodes, gtype[gb].name, R->etag[q], gtype[gb].name, R->etag[p],
                       W(R, R->eline[p]));
      else
        st = msh_error(R, MO_EINPUT, R->eline[q], "%s %lld and %s %lld (%s) lie on the same side of "
                       "their common %s (nodes %s): the mesh folds over itself there", gtype[gb].name,
                       R->etag[q], gtype[gb].name, R->etag[p], W(R, R->eline[p]), side_word[T->dim], nodes);
    }
  }
  mo_free(S);
  return st;
}

/* Per physical name: its nodes and its facets (file elements of dimension D - 1). */
typedef struct {
  char *name;
  int *node;
  size_t nnode, capnode;
  int *facet;
  size_t nfacet, capfacet;
} msh_set;

typedef struct {
  int dim, tag, set;
} msh_group;

static int cmp_group(const void *a, const void *b)
{
  const msh_group *p = a, *q = b;
  if (p->dim != q->dim) return (p->dim > q->dim) - (p->dim < q->dim);
  return (p->tag > q->tag) - (p->tag < q->tag);
}

static int build(msh *R, const mo_gmsh_options *opt, mo_mesh **out, mo_gmsh_report *rep)
{
  mo_ctx *ctx = R->ctx;
  msh_tagidx *order = NULL;
  int *newid = NULL, *body = NULL, *fn = NULL, *fe = NULL, *fl = NULL;
  msh_elkey *keys = NULL;
  msh_group *grp = NULL;
  msh_set *set = NULL;
  unsigned char *drop = NULL;
  mo_mesh *m = NULL;
  void *gp;
  size_t e, i, ngrp = 0, nset = 0, nbody = 0, nkeep = 0, capgrp = 0;
  int *fileof = NULL;
  int D = -1, gb = -1, st = MO_OK, nused = 0, nreor = 0, a, d, k;
  long first_body = 0;
  double scale = opt ? opt->scale : 1, ext = 0;
  *out = NULL;

  if (!(scale > 0) || !isfinite(scale))
    return mo_error(ctx, MO_EINPUT, "%s: the scale %g is not a positive number", R->file, scale);
  for (d = 0; opt && d < 3; d++)
    if (!isfinite(opt->translate[d]))
      return mo_error(ctx, MO_EINPUT, "%s: the translation is not finite", R->file);

  /* the body: the elements of the highest dimension, one type */
  for (e = 0; e < R->nel; e++)
    if (gtype[R->etype[e]].dim > D) D = gtype[R->etype[e]].dim;
  if (D <= 0)
    return msh_error(R, MO_EINPUT, R->sec_line[S_ELEMENTS], "%s: no line, surface or volume element to "
                     "make a body of", R->nel ? "only points" : "no elements");
  for (e = 0; e < R->nel; e++) {
    if (gtype[R->etype[e]].dim != D) continue;
    if (gb < 0) {
      gb = R->etype[e];
      first_body = R->eline[e];
    } else if (R->etype[e] != gb)
      return msh_error(R, MO_EINPUT, R->eline[e], "element %lld is a %s, but the element at %s is "
                       "a %s: a body has one element type (recombine every surface into quadrangles, "
                       "or none; one Mesh.ElementOrder)", R->etag[e], gtype[R->etype[e]].name, W(R, first_body),
                       gtype[gb].name);
    nbody++;
  }
  if (gb == G_LINE3)
    return msh_error(R, MO_EINPUT, first_body, "the body would be made of 3-node lines: moreau's 1D element is the "
                     "2-node bar (save a 1D mesh with Mesh.ElementOrder = 1); 3-node lines are the sides of 6-node "
                     "triangles");
  if (nbody > (size_t)INT_MAX / MO_NEN_MAX)
    return msh_error(R, MO_ELIMIT, R->sec_line[S_ELEMENTS], "%zu body elements", nbody);

  /* node tags: sorted, unique */
  order = mo_malloc(ctx, (R->nnode ? R->nnode : 1) * sizeof *order);
  newid = mo_malloc(ctx, (R->nnode ? R->nnode : 1) * sizeof *newid);
  if (!order || !newid) { st = MO_ENOMEM; goto done; }
  for (i = 0; i < R->nnode; i++) {
    order[i].tag = R->ntag[i];
    order[i].idx = i;
    newid[i] = -1;
  }
  qsort(order, R->nnode, sizeof *order, cmp_tagidx);
  for (i = 1; i < R->nnode; i++)
    if (order[i].tag == order[i - 1].tag) {
      st = msh_error(R, MO_EINPUT, R->nline[order[i].idx], "node %lld is defined twice (first at %s)",
                     order[i].tag, W(R, R->nline[order[i - 1].idx]));
      goto done;
    }

  /* entities and physical names: sorted, unique */
  if (R->nent) qsort(R->ent, R->nent, sizeof *R->ent, cmp_entity);
  for (i = 1; i < R->nent; i++)
    if (R->ent[i].dim == R->ent[i - 1].dim && R->ent[i].tag == R->ent[i - 1].tag) {
      st = msh_error(R, MO_EINPUT, R->ent[i].line, "%s %d is defined twice (first at %s)",
                     dim_word(R->ent[i].dim), R->ent[i].tag, W(R, R->ent[i - 1].line));
      goto done;
    }
  if (R->npn) qsort(R->pn, R->npn, sizeof *R->pn, cmp_pname);
  for (i = 1; i < R->npn; i++)
    if (R->pn[i].dim == R->pn[i - 1].dim && R->pn[i].tag == R->pn[i - 1].tag) {
      st = msh_error(R, MO_EINPUT, R->pn[i].line, "physical %s %d is named twice (first at %s)",
                     dim_word(R->pn[i].dim), R->pn[i].tag, W(R, R->pn[i - 1].line));
      goto done;
    }
  if (R->npn > 1) {
    /* two groups of one name: a set is found by name, so their nodes and facets would merge */
    const msh_pname **by = mo_malloc(ctx, R->npn * sizeof *by);
    if (!by) { st = MO_ENOMEM; goto done; }
    for (i = 0; i < R->npn; i++) by[i] = &R->pn[i];
    qsort(by, R->npn, sizeof *by, cmp_pname_name);
    for (i = 1; i < R->npn && !st; i++)
      if (by[i]->dim == by[i - 1]->dim && !strcmp(by[i]->name, by[i - 1]->name))
        st = msh_error(R, MO_EINPUT, by[i]->line, "physical %ss %d and %d are both named %s (first at %s): "
                       "the set of that name would merge them; give each group its own name",
                       dim_word(by[i]->dim), by[i - 1]->tag, by[i]->tag, by[i]->name, W(R, by[i - 1]->line));
    mo_free(by);
    if (st) goto done;
  }
  if (R->version == 41 && R->npn && !R->sec_line[S_ENTITIES]) {
    st = msh_error(R, MO_EINPUT, R->sec_line[S_NAMES], "physical names, but no $Entities section to "
                   "attach the groups to elements");
    goto done;
  }

  /* node tags of the elements that matter (the body's, and those of physical groups) become
     file node indices; each element lists distinct, existing nodes */
  for (e = 0; e < R->nel; e++) {
    const int *ph;
    int nph, g = R->etype[e], nen = gtype[g].nen;
    long long *t = &R->enode[R->eoff[e]];
    if ((st = element_physicals(R, e, &ph, &nph))) goto done;
    if (gtype[g].dim != D && nph == 0) continue;
    for (a = 0; a < nen; a++)
      for (k = 0; k < a; k++)
        if (t[k] == t[a]) {
          st = msh_error(R, MO_EINPUT, R->eline[e], "%s %lld lists node %lld twice", gtype[g].name,
                         R->etag[e], t[a]);
          goto done;
        }
    for (a = 0; a < nen; a++) {
      msh_tagidx *hit = NULL;
      size_t lo = 0, hi = R->nnode;
      while (lo < hi) { /* the node of tag t[a] among the sorted tags */
        size_t mid = lo + (hi - lo) / 2;
        if (order[mid].tag < t[a]) lo = mid + 1;
        else hi = mid;
      }
      if (lo < R->nnode && order[lo].tag == t[a]) hit = &order[lo];
      if (!hit) {
        st = msh_error(R, MO_EINPUT, R->eline[e], "%s %lld refers to node %lld, which $Nodes (%s) "
                       "does not define", gtype[g].name, R->etag[e], t[a], W(R, R->sec_line[S_NODES]));
        goto done;
      }
      t[a] = (long long)hit->idx;
      if (gtype[g].dim == D) newid[hit->idx] = 0; /* used */
    }
  }
  /* compact numbering in increasing tag order */
  for (i = 0; i < R->nnode; i++)
    if (newid[order[i].idx] == 0) newid[order[i].idx] = ++nused;
  for (i = 0; i < R->nnode; i++) newid[i] = newid[i] > 0 ? newid[i] - 1 : -1;

  /* a 1D body lies on the x axis, a 2D one in the plane z = 0 */
  {
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (i = 0; i < R->nnode; i++)
      if (newid[i] >= 0)
        for (d = 0; d < 3; d++) {
          if (R->nx[3 * i + (size_t)d] < lo[d]) lo[d] = R->nx[3 * i + (size_t)d];
          if (R->nx[3 * i + (size_t)d] > hi[d]) hi[d] = R->nx[3 * i + (size_t)d];
        }
    for (d = 0; d < D; d++)
      if (hi[d] - lo[d] > ext) ext = hi[d] - lo[d];
    for (i = 0; D < 3 && i < R->nnode; i++)
      if (newid[i] >= 0)
        for (d = D; d < 3; d++)
          if (fabs(R->nx[3 * i + (size_t)d]) > 1e-10 * ext) {
            st = msh_error(R, MO_EINPUT, R->nline[i], "node %lld has %c = %g, but a %s body lies %s: the "
                           "file's highest-dimensional elements are %s%s", R->ntag[i], "xyz"[d],
                           R->nx[3 * i + (size_t)d], D == 1 ? "1D" : "2D",
                           D == 1 ? "on the x axis" : "in the plane z = 0", gtype[gb].names,
                           D < 3 ? " (Gmsh saves only the elements of physical groups once there are "
                                   "some: add a physical group for the body, or set Mesh.SaveAll = 1)" : "");
            goto done;
          }
  }

  /* the mesh: coordinates and connectivity of the body elements */
  m = mo_calloc(ctx, 1, sizeof *m);
  if (!m) { st = MO_ENOMEM; goto done; }
  m->dim = D;
  m->nnode = nused;
  m->type = gtype[gb].mo;
  m->nen = gtype[gb].nen;
  m->x = mo_malloc(ctx, (size_t)(nused ? nused : 1) * (size_t)D * sizeof(double));
  body = mo_malloc(ctx, (nbody ? nbody : 1) * sizeof *body);
  m->conn = mo_malloc(ctx, (nbody ? nbody : 1) * (size_t)m->nen * sizeof(int));
  drop = mo_calloc(ctx, nbody ? nbody : 1, 1);
  if (!m->x || !m->conn || !body || !drop) { st = MO_ENOMEM; goto done; }
  for (i = 0; i < R->nnode; i++)
    if (newid[i] >= 0)
      for (d = 0; d < D; d++)
        m->x[(size_t)newid[i] * (size_t)D + (size_t)d] =
            scale * R->nx[3 * i + (size_t)d] + (opt ? opt->translate[d] : 0);
  /* a scale that overflows (or squares past the range, as element Jacobians do) */
  for (i = 0; i < (size_t)nused * (size_t)D; i++)
    if (!(fabs(m->x[i]) < 1e150)) {
      st = mo_error(ctx, MO_EINPUT, "%s: the scale %g and translation take a coordinate to %g: past 1e150, where "
                    "lengths squared overflow (a scale in metres, please)", R->file, scale, m->x[i]);
      goto done;
    }
  for (e = 0, k = 0; e < R->nel; e++)
    if (gtype[R->etype[e]].dim == D) {
      body[k] = (int)e;
      for (a = 0; a < m->nen; a++)
        m->conn[(size_t)k * (size_t)m->nen + (size_t)a] = newid[R->enode[R->eoff[e] + (size_t)a]];
      k++;
    }

  /* repeated elements: MSH 2.2 writes an element once per physical group it belongs to */
  keys = mo_malloc(ctx, (nbody ? nbody : 1) * sizeof *keys);
  if (!keys) { st = MO_ENOMEM; goto done; }
  for (i = 0; i < nbody; i++) {
    for (a = 0; a < MO_NEN_MAX; a++) keys[i].key[a] = a < m->nen ? m->conn[i * (size_t)m->nen + (size_t)a] : -1;
    qsort(keys[i].key, (size_t)m->nen, sizeof(int), cmp_int1);
    keys[i].el = (int)i;
  }
  qsort(keys, nbody, sizeof *keys, cmp_elkey);
  for (i = 1; i < nbody; i++)
    if (!memcmp(keys[i].key, keys[i - 1].key, sizeof keys[i].key)) {
      size_t p = (size_t)keys[i - 1].el, q = (size_t)keys[i].el;
      int same = !memcmp(&m->conn[p * (size_t)m->nen], &m->conn[q * (size_t)m->nen],
                         (size_t)m->nen * sizeof(int));
      if (R->version != 22 || !same) {
        st = msh_error(R, MO_EINPUT, R->eline[body[q]], "%s %lld has the nodes of %s %lld (%s)",
                       gtype[gb].name, R->etag[body[q]], gtype[gb].name, R->etag[body[p]], W(R, R->eline[body[p]]));
        goto done;
      }
      drop[q] = 1;
      keys[i].el = keys[i - 1].el; /* later repeats compare with the one kept */
    }
  for (i = 0; i < nbody; i++) {
    if (drop[i]) continue;
    if (nkeep != i) {
      memmove(&m->conn[nkeep * (size_t)m->nen], &m->conn[i * (size_t)m->nen], (size_t)m->nen * sizeof(int));
      body[nkeep] = body[i];
    }
    nkeep++;
  }
  m->nelem = (int)nkeep;

  /* orientation and shape */
  fileof = mo_malloc(ctx, (size_t)(nused ? nused : 1) * sizeof *fileof);
  if (!fileof) { st = MO_ENOMEM; goto done; }
  for (i = 0; i < R->nnode; i++)
    if (newid[i] >= 0) fileof[newid[i]] = (int)i;
  if ((st = check_shapes(R, m, body, fileof, gb, &nreor))) goto done;
  if ((st = check_folds(R, m, body, fileof, gb))) goto done;
  if (nreor)
    mo_log(ctx, 1, "%s: note: %d of %d %s were written clockwise (negative Jacobian) and were "
           "reoriented\n", R->file, nreor, m->nelem, gtype[gb].names);

  /* physical groups: (dim, tag) pairs, each with a set name (groups sharing a name merge) */
  for (e = 0; e < R->nel; e++) {
    const int *ph;
    int nph, j;
    if ((st = element_physicals(R, e, &ph, &nph))) goto done;
    for (j = 0; j < nph; j++) {
      if (ngrp && grp[ngrp - 1].dim == gtype[R->etype[e]].dim && grp[ngrp - 1].tag == ph[j]) continue;
      if (!(gp = msh_grow(ctx, grp, &capgrp, ngrp + 1, sizeof *grp))) { st = MO_ENOMEM; goto done; }
      grp = gp;
      grp[ngrp].dim = gtype[R->etype[e]].dim;
      grp[ngrp].tag = ph[j];
      grp[ngrp].set = -1;
      ngrp++;
    }
  }
  for (i = 0; i < R->npn; i++) { /* named groups without elements give empty node sets */
    if (!(gp = msh_grow(ctx, grp, &capgrp, ngrp + 1, sizeof *grp))) { st = MO_ENOMEM; goto done; }
    grp = gp;
    grp[ngrp].dim = R->pn[i].dim;
    grp[ngrp].tag = R->pn[i].tag;
    grp[ngrp].set = -1;
    ngrp++;
  }
  if (ngrp) qsort(grp, ngrp, sizeof *grp, cmp_group);
  {
    size_t u = 0;
    for (i = 0; i < ngrp; i++)
      if (u == 0 || cmp_group(&grp[u - 1], &grp[i])) grp[u++] = grp[i];
    ngrp = u;
  }
  set = mo_calloc(ctx, ngrp ? ngrp : 1, sizeof *set);
  if (!set) { st = MO_ENOMEM; goto done; }
  for (i = 0; i < ngrp; i++) {
    char dflt[32];
    const char *nm = NULL;
    size_t lo = 0, hi = R->npn, s;
    while (lo < hi) {
      size_t mid = lo + (hi - lo) / 2;
      const msh_pname *P = &R->pn[mid];
      int c = P->dim != grp[i].dim ? (P->dim > grp[i].dim) - (P->dim < grp[i].dim)
                                   : (P->tag > grp[i].tag) - (P->tag < grp[i].tag);
      if (c == 0) { nm = P->name; break; }
      if (c < 0) lo = mid + 1;
      else hi = mid;
    }
    if (!nm) {
      snprintf(dflt, sizeof dflt, "%s%d", dim_word(grp[i].dim), grp[i].tag);
      nm = dflt;
    }
    for (s = 0; s < nset && strcmp(set[s].name, nm); s++) {}
    if (s == nset) {
      if (!(set[nset].name = mo_strdup(ctx, nm))) { st = MO_ENOMEM; goto done; }
      nset++;
    }
    grp[i].set = (int)s;
  }

  /* nodes and facets of every set */
  for (e = 0; e < R->nel; e++) {
    const int *ph;
    int nph, j, g = R->etype[e], dim = gtype[g].dim;
    if ((st = element_physicals(R, e, &ph, &nph))) goto done;
    for (j = 0; j < nph; j++) {
      msh_group key, *G;
      msh_set *S;
      key.dim = dim;
      key.tag = ph[j];
      G = bsearch(&key, grp, ngrp, sizeof *grp, cmp_group);
      if (!G) { st = mo_error(ctx, MO_EINTERNAL, "gmsh: a physical group went missing"); goto done; }
      S = &set[G->set];
      if (!(gp = msh_grow(ctx, S->node, &S->capnode, S->nnode + (size_t)gtype[g].nen, sizeof(int)))) {
        st = MO_ENOMEM;
        goto done;
      }
      S->node = gp;
      for (a = 0; a < gtype[g].nen; a++) {
        size_t fi = (size_t)R->enode[R->eoff[e] + (size_t)a];
        if (newid[fi] < 0) {
          st = msh_error(R, MO_EINPUT, R->eline[e], "node %lld of %s %lld (physical group '%s') is not a "
                         "node of any %s", R->ntag[fi], gtype[g].name, R->etag[e], S->name, gtype[gb].name);
          goto done;
        }
        S->node[S->nnode++] = newid[fi];
      }
      if (dim == D - 1) {
        if (!(gp = msh_grow(ctx, S->facet, &S->capfacet, S->nfacet + 1, sizeof(int)))) {
          st = MO_ENOMEM;
          goto done;
        }
        S->facet = gp;
        S->facet[S->nfacet++] = (int)e;
      }
    }
  }
  /* facet sets: the group's facets all on the boundary, or all inside (node set only); located
     in one pass for all groups */
  {
    const mo_eltype_info *T = mo_eltype_get(m->type);
    size_t f, nft = 0, off;
    for (i = 0; i < nset; i++) nft += set[i].nfacet;
    fn = mo_malloc(ctx, (nft ? nft : 1) * (size_t)T->nfn * sizeof(int));
    fe = mo_malloc(ctx, (nft ? nft : 1) * sizeof(int));
    fl = mo_malloc(ctx, (nft ? nft : 1) * sizeof(int));
    if (!fn || !fe || !fl) { st = MO_ENOMEM; goto done; }
    for (i = 0, off = 0; i < nset; i++)
      for (f = 0; f < set[i].nfacet; f++, off++) {
        size_t el = (size_t)set[i].facet[f];
        int g = R->etype[el];
        if (gtype[g].nen != T->nfn) {
          st = msh_error(R, MO_EINPUT, R->eline[el], "%s %lld (physical group '%s') cannot be a side of a %s",
                         gtype[g].name, R->etag[el], set[i].name, gtype[gb].name);
          goto done;
        }
        for (a = 0; a < T->nfn; a++)
          fn[off * (size_t)T->nfn + (size_t)a] = newid[R->enode[R->eoff[el] + (size_t)a]];
      }
    if (nft && (st = mo_mesh_locate_facets(m, fn, (int)nft, fe, fl, ctx))) goto done;
    for (i = 0, off = 0; i < nset; off += set[i].nfacet, i++) {
      msh_set *S = &set[i];
      int *se = fe + off, *sl = fl + off;
      size_t nb = 0, nin = 0, first_in = 0, first_b = 0;
      for (f = 0; f < S->nfacet; f++) {
        size_t el = (size_t)S->facet[f];
        if (se[f] == -1) {
          st = msh_error(R, MO_EINPUT, R->eline[el], "%s %lld (physical group '%s') is not a side of any %s "
                         "(is the mesh conforming?)", gtype[R->etype[el]].name, R->etag[el], S->name,
                         gtype[gb].name);
          goto done;
        }
        if (se[f] == -2) {
          if (!nin++) first_in = el;
        } else {
          if (!nb++) first_b = el;
          se[nb - 1] = se[f];
          sl[nb - 1] = sl[f];
        }
      }
      if (nb && nin) {
        st = msh_error(R, MO_EINPUT, R->eline[first_in], "physical group '%s' has %s %lld inside the body and "
                       "%s %lld (%s) on its boundary: a group of %s lies on the boundary (a facet "
                       "set for loads and contact) or inside (a node set)", S->name,
                       gtype[R->etype[first_in]].name, R->etag[first_in], gtype[R->etype[first_b]].name,
                       R->etag[first_b], W(R, R->eline[first_b]), gtype[R->etype[first_b]].names);
        goto done;
      }
      if (nb && (st = mo_mesh_add_facetset(m, S->name, se, sl, (int)nb, ctx))) goto done;
      if (nin)
        mo_log(ctx, 2, "%s: physical group '%s' lies inside the body: a node set, no facet set\n", R->file,
               S->name);
    }
  }
  for (i = 0; i < nset; i++)
    if ((st = mo_mesh_add_nodeset(m, set[i].name, set[i].node, (int)set[i].nnode, ctx))) goto done;
  if (!mo_mesh_find_nodeset(m, "all")) {
    int *all = mo_malloc(ctx, (size_t)(nused ? nused : 1) * sizeof(int));
    if (!all) { st = MO_ENOMEM; goto done; }
    for (k = 0; k < nused; k++) all[k] = k;
    st = mo_mesh_add_nodeset(m, "all", all, nused, ctx);
    mo_free(all);
    if (st) goto done;
  }
  if (rep) {
    rep->nreoriented = nreor;
    rep->version = R->version;
    rep->nunused = (int)R->nnode - nused;
    rep->nduplicate = (int)(nbody - nkeep);
    rep->binary = R->binary;
  }
  *out = m;
  m = NULL;
done:
  for (i = 0; set && i < nset; i++) {
    mo_free(set[i].name);
    mo_free(set[i].node);
    mo_free(set[i].facet);
  }
  mo_free(set);
  mo_free(grp);
  mo_free(keys);
  mo_free(drop);
  mo_free(body);
  mo_free(fn);
  mo_free(fe);
  mo_free(fl);
  mo_free(order);
  mo_free(newid);
  mo_free(fileof);
  mo_mesh_free(m);
  return st;
}

static int read_stream(FILE *f, const char *name, const mo_gmsh_options *opt, mo_mesh **out,
                       mo_gmsh_report *rep, mo_ctx *ctx)
{
  msh R;
  long long lim = ctx->max_dofs > 0 ? ctx->max_dofs : 20000000LL;
  int st;
  memset(&R, 0, sizeof R);
  R.f = f;
  R.file = name;
  R.at = 1;
  R.ctx = ctx;
  if (lim > INT_MAX / 8) lim = INT_MAX / 8;
  R.max_nodes = lim;
  R.max_elems = 2 * lim;
  if (rep) memset(rep, 0, sizeof *rep);
  st = read_sections(&R);
  if (!st) st = build(&R, opt, out, rep);
  msh_release(&R);
  return st;
}

int mo_mesh_read_gmsh(const char *path, const mo_gmsh_options *opt, mo_mesh **out,
                      mo_gmsh_report *rep, mo_ctx *ctx)
{
  FILE *f;
  int st;
  struct stat sb;
  *out = NULL;
  /* a bounded input: a regular file (a FIFO would block the open) of at most MO_MESH_FILE_MAX
     bytes (10^7 elements of text take about 600 MB) */
  if (stat(path, &sb) == 0 && !S_ISREG(sb.st_mode))
    return mo_error(ctx, MO_EINPUT, "%s: not a regular file (a mesh file is read whole)", path);
  f = fopen(path, "r");
  if (!f) return mo_error(ctx, MO_EIO, "cannot read the mesh file %s (%s)", path, strerror(errno));
  if (fstat(fileno(f), &sb) != 0 || !S_ISREG(sb.st_mode)) {
    fclose(f);
    return mo_error(ctx, MO_EINPUT, "%s: not a regular file (a mesh file is read whole)", path);
  }
  if ((double)sb.st_size > MO_MESH_FILE_MAX) {
    fclose(f);
    return mo_error(ctx, MO_ELIMIT, "%s: %.3g bytes, more than the %.3g bytes a mesh file may hold", path,
                    (double)sb.st_size, MO_MESH_FILE_MAX);
  }
  st = read_stream(f, path, opt, out, rep, ctx);
  fclose(f);
  return st;
}

int mo_mesh_read_gmsh_buffer(const char *buf, size_t len, const char *name,
                             const mo_gmsh_options *opt, mo_mesh **out, mo_gmsh_report *rep,
                             mo_ctx *ctx)
{
  FILE *f;
  int st;
  *out = NULL;
  if (len == 0) return mo_error(ctx, MO_EINPUT, "%s: the file is empty: expected $MeshFormat", name);
  f = fmemopen((void *)buf, len, "r");
  if (!f) return mo_error(ctx, MO_EIO, "%s: cannot read the buffer (%s)", name, strerror(errno));
  st = read_stream(f, name, opt, out, rep, ctx);
  fclose(f);
  return st;
}
