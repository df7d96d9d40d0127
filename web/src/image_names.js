// The name a photo has in an image set, by the server's rule (api/image_names.h): the file
// name without a directory, every byte of its UTF-8 form that is not a letter, digit, '.', '-'
// or '_' replaced by '_' (so "día" is "d__a", as the multipart upload stores it), no leading
// dot, at most 200 characters (the end kept, with the extension). The server refuses any
// other name and names the clean one; tests/api/image_names_cases.json holds the cases both
// copies of the rule are checked against.
const ALLOWED = /[A-Za-z0-9._-]/;

export function cleanImageName(name) {
  const base = name.slice(Math.max(name.lastIndexOf('/'), name.lastIndexOf('\\')) + 1);
  let clean = '';
  for (const ch of base) {
    clean += ALLOWED.test(ch) ? ch : '_'.repeat(new TextEncoder().encode(ch).length);
  }
  clean = clean.replace(/^\.+/, '');
  return clean.length > 200 ? clean.slice(clean.length - 200) : clean;
}
