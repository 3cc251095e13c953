/* knit_chart.c: knit charts (DESIGN §3): the built-in stitch patterns and
 * the chart file format (one row of stitch codes per course, bottom
 * course first, codes separated by blanks, '#' comments).  K (knit) and P
 * (purl) are supported; the other codes of the Leaf et al. lexicon are
 * recognised and refused with a message that says so. */
#include <vkyarn.h>
#include <vkio.h>
#include <ctype.h>
#include <string.h>

const char *const VKKnitBuiltins[] = {"stockinette", "garter", "rib1x1", "rib2x2", "seed", "basketweave", NULL};

/* Rows bottom first, one character per stitch (chart-internal shorthand). */
static const char *const *BuiltinRows(const char name[], PetscInt *nrows)
{
  static const char *stockinette[] = {"K"};
  static const char *garter[]      = {"K", "P"};
  static const char *rib1x1[]      = {"KP"};
  static const char *rib2x2[]      = {"KKPP"};
  static const char *seed[]        = {"KP", "PK"};
  static const char *basket[]      = {"KKKKPPPP", "KKKKPPPP", "KKKKPPPP", "KKKKPPPP", "PPPPKKKK", "PPPPKKKK", "PPPPKKKK", "PPPPKKKK"};
  static const struct {
    const char  *name;
    const char **rows;
    PetscInt     n;
  } table[] = {
    {"stockinette", stockinette, 1},
    {"garter",      garter,      2},
    {"rib1x1",      rib1x1,      1},
    {"rib2x2",      rib2x2,      1},
    {"seed",        seed,        2},
    {"basketweave", basket,      8}
  };
  for (size_t i = 0; i < sizeof(table) / sizeof(table[0]); i++)
    if (!strcmp(name, table[i].name)) {
      *nrows = table[i].n;
      return table[i].rows;
    }
  return NULL;
}

PetscErrorCode VKKnitChartBuiltin(const char name[], VKKnitChart *chart)
{
  const char *const *rows;
  PetscInt           n = 0;

  PetscFunctionBegin;
  rows = BuiltinRows(name, &n);
  PetscCheck(rows, PETSC_COMM_SELF, PETSC_ERR_ARG_UNKNOWN_TYPE, "Unknown knit pattern '%s' (-yarn_pattern): choose stockinette, garter, rib1x1, rib2x2, seed or basketweave", name);
  chart->rows = n;
  chart->cols = (PetscInt)strlen(rows[0]);
  PetscCall(PetscMalloc1(chart->rows * chart->cols, &chart->sign));
  for (PetscInt r = 0; r < n; r++)
    for (PetscInt c = 0; c < chart->cols; c++) chart->sign[r * chart->cols + c] = rows[r][c] == 'K' ? 1 : -1;
  PetscFunctionReturn(0);
}

PetscErrorCode VKKnitChartFree(VKKnitChart *chart)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(chart->sign));
  chart->rows = chart->cols = 0;
  PetscFunctionReturn(0);
}

static PetscBool IsLexiconCode(const char *tok, size_t n)
{
  static const char *codes[] = {"F", "B", "YS", "2U", "Y3Y"};
  for (size_t i = 0; i < sizeof(codes) / sizeof(codes[0]); i++)
    if (strlen(codes[i]) == n && !strncmp(tok, codes[i], n)) return PETSC_TRUE;
  return PETSC_FALSE;
}

/* The chart is parsed in two passes over the text: the first counts and
 * checks, the second fills.  Nothing is allocated before the text is
 * known to be valid, so a bad chart leaks nothing. */
PetscErrorCode VKKnitChartParse(const char buf[], size_t len, const char fname[], VKKnitChart *chart)
{
  PetscFunctionBegin;
  VKSkipByteOrderMark(&buf, &len);
  chart->rows = chart->cols = 0;
  chart->sign               = NULL;
  for (int pass = 0; pass < 2; pass++) {
    size_t   pos = 0;
    PetscInt line = 0, row = 0, firstline = 0;

    while (pos < len) {
      size_t   end = pos, p;
      PetscInt ncol = 0;

      while (end < len && buf[end] != '\n') end++;
      line++;
      for (p = pos; p < end;) {
        size_t s;
        if (buf[p] == '#') break;
        if (isspace((unsigned char)buf[p])) {
          p++;
          continue;
        }
        s = p;
        while (p < end && !isspace((unsigned char)buf[p]) && buf[p] != '#') p++;
        if (p - s == 1 && (buf[s] == 'K' || buf[s] == 'k' || buf[s] == 'P' || buf[s] == 'p')) {
          if (pass == 1) chart->sign[row * chart->cols + ncol] = (buf[s] == 'K' || buf[s] == 'k') ? 1 : -1;
          ncol++;
          PetscCheck(ncol <= 1000000, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: more than 10^6 stitches in a row", fname, (int)line);
          continue;
        }
        for (size_t q = s; q < p; q++) PetscCheck(buf[q] != 0 && isprint((unsigned char)buf[q]), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: column %d: unreadable character (byte 0x%02x): a chart is text", fname, (int)line, (int)(q - pos + 1), (unsigned char)buf[q]);
        PetscCheck(!IsLexiconCode(buf + s, p - s), PETSC_COMM_SELF, PETSC_ERR_SUP, "%s:%d: stitch code '%.*s' (column %d) is in the Leaf et al. lexicon but not supported yet; supported codes: K P", fname, (int)line, (int)(p - s), buf + s, (int)(s - pos + 1));
        SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: unknown stitch code '%.*s' (column %d); supported codes: K P", fname, (int)line, (int)PetscMin(p - s, 16), buf + s, (int)(s - pos + 1));
      }
      if (ncol > 0) {
        if (row == 0) {
          firstline = line;
          if (pass == 0) chart->cols = ncol;
        }
        PetscCheck(ncol == chart->cols, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: ragged chart: this row has %d stitches, row 1 (line %d) has %d", fname, (int)line, (int)ncol, (int)firstline, (int)chart->cols);
        row++;
        PetscCheck(row <= 1000000, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: more than 10^6 rows", fname);
      }
      pos = end + 1;
    }
    if (pass == 0) {
      PetscCheck(row > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: the chart has no stitches", fname);
      chart->rows = row;
      PetscCheck((double)chart->rows * (double)chart->cols <= 1e7, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: chart of %d x %d stitches is larger than 10^7", fname, (int)chart->rows, (int)chart->cols);
      PetscCall(PetscMalloc1(chart->rows * chart->cols, &chart->sign));
    }
  }
  PetscFunctionReturn(0);
}
