// The names photos of a job are stored under on the server. A client names its files
// (DJI_0042.JPG, or "../../etc/x.jpg" from a hostile one); the server keeps only a plain file
// name, so a photo can never land outside its job's folder, and refuses what the image-folder
// reader would not read as a photo. Shared by the multipart upload (POST /api/v1/jobs, fields
// "images") and the resumable image set (PUT /api/v1/uploads/{id}/images/{name}).
#pragma once

#include <cstddef>
#include <string>

namespace glam::api {

// Photos per job: large surveys have a few thousand.
inline constexpr std::size_t kMaxImagesPerJob = 20000;

// The client's file name without any directory part, with every character but letters,
// digits, '.', '-' and '_' replaced by '_', no leading dot, at most 200 characters (the end
// kept, so the extension stays). Empty when nothing is left or it lacks an image extension
// (.jpg, .jpeg, .png, .tif, .tiff, .bmp, .webp).
std::string SafeImageName(const std::string& client_name);

// The message for a name SafeImageName refuses.
std::string NotAnImageNameMessage(const std::string& client_name);

// Empty when `name` is already as SafeImageName makes it; otherwise why not, naming the clean
// form to send instead. An image set checks names rather than changing them: the name a
// client sends is the one it later finds in the set's list, so it knows what is there.
std::string UncleanImageNameMessage(const std::string& name);

}  // namespace glam::api
