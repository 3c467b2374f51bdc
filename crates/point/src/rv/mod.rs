//! RV: conservative streaming from-point visibility in bounded memory (Ivanchenko 2021).
//! Being written.
