// ogden: being written
